package org.openair;

/**
 * The connection is closed or was lost, so the operation cannot complete (CONNECTION_CLOSED).
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class ConnectionClosedException extends LocalProtocolException {
    private static final long serialVersionUID = 1L;

    /**
     * Create the error.
     *
     * @param detail a human-readable explanation (may be empty)
     */
    public ConnectionClosedException(String detail) {
        super(ErrorCode.CONNECTION_CLOSED, detail);
    }
}
