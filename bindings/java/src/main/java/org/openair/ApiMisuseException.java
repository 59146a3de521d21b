package org.openair;

/**
 * The API was used in a way the protocol does not allow (API_MISUSE): a bad argument, a call in the wrong state, a character XML cannot carry (OA-MSG-14).
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class ApiMisuseException extends LocalProtocolException {
    private static final long serialVersionUID = 1L;

    /**
     * Create the error.
     *
     * @param detail a human-readable explanation (may be empty)
     */
    public ApiMisuseException(String detail) {
        super(ErrorCode.API_MISUSE, detail);
    }
}
