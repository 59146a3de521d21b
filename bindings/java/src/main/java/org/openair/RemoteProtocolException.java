package org.openair;

/**
 * An error whose blame is remote: the peer violated the protocol (blame `remote`): malformed frames or XML, invalid slots.
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class RemoteProtocolException extends OpenAirException {
    private static final long serialVersionUID = 1L;

    /**
     * Create the error.
     *
     * @param code a condition whose blame is {@code REMOTE}
     * @param detail a human-readable explanation (may be empty)
     * @throws IllegalArgumentException if the code's blame is not {@code REMOTE}
     */
    public RemoteProtocolException(ErrorCode code, String detail) {
        super(requireBlame(code), detail);
    }

    private static ErrorCode requireBlame(ErrorCode code) {
        if (code.blame() != ErrorCode.Blame.REMOTE) {
            throw new IllegalArgumentException(code + " is not a remote condition");
        }
        return code;
    }
}
