package org.openair;

/**
 * No reply arrived within the request timeout (REQUEST_TIMEOUT, OA-SESS-27); the connection it was sent on is closed, since a late reply could no longer be paired.
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class RequestTimeoutException extends LocalProtocolException {
    private static final long serialVersionUID = 1L;

    /**
     * Create the error.
     *
     * @param detail a human-readable explanation (may be empty)
     */
    public RequestTimeoutException(String detail) {
        super(ErrorCode.REQUEST_TIMEOUT, detail);
    }
}
