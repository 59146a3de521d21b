package org.openair;

/**
 * An error whose blame is local: a local condition (blame `local`): API misuse, a closed connection, a timeout; never sent on the wire (OA-ERR-7).
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class LocalProtocolException extends OpenAirException {
    private static final long serialVersionUID = 1L;

    /**
     * Create the error.
     *
     * @param code a condition whose blame is {@code LOCAL}
     * @param detail a human-readable explanation (may be empty)
     * @throws IllegalArgumentException if the code's blame is not {@code LOCAL}
     */
    public LocalProtocolException(ErrorCode code, String detail) {
        super(requireBlame(code), detail);
    }

    private static ErrorCode requireBlame(ErrorCode code) {
        if (code.blame() != ErrorCode.Blame.LOCAL) {
            throw new IllegalArgumentException(code + " is not a local condition");
        }
        return code;
    }
}
