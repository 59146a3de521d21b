package org.openair;

/**
 * An error whose blame is peer: the peer's state or a resource refused a well-formed request (blame `peer`).
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class PeerException extends OpenAirException {
    private static final long serialVersionUID = 1L;

    /**
     * Create the error.
     *
     * @param code a condition whose blame is {@code PEER}
     * @param detail a human-readable explanation (may be empty)
     * @throws IllegalArgumentException if the code's blame is not {@code PEER}
     */
    public PeerException(ErrorCode code, String detail) {
        super(requireBlame(code), detail);
    }

    private static ErrorCode requireBlame(ErrorCode code) {
        if (code.blame() != ErrorCode.Blame.PEER) {
            throw new IllegalArgumentException(code + " is not a peer condition");
        }
        return code;
    }
}
