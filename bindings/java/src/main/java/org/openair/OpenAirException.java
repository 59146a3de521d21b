package org.openair;

import java.util.Objects;

/**
 * An OpenAIR error condition: one row of the spec's error table ({@link ErrorCode}).
 *
 * <p>The subclasses split the blame (spec 13.1, OA-GEN-3): {@link RemoteProtocolException} (the
 * peer broke the protocol), {@link PeerException} (the peer refused a well-formed request) and
 * {@link LocalProtocolException} (this side's API was misused, or a local condition such as a
 * timeout). Use {@link #of(ErrorCode, String)} to get the right subclass for a code.
 *
 * <p>Threading: exceptions are immutable after construction and may be passed between threads.
 */
public class OpenAirException extends RuntimeException {
    private static final long serialVersionUID = 1L;

    private final ErrorCode code;
    private final String detail;

    /**
     * Create an error for a condition of the table.
     *
     * @param code the condition
     * @param detail a human-readable explanation (may be empty)
     */
    protected OpenAirException(ErrorCode code, String detail) {
        super(detail == null || detail.isEmpty() ? code.name() : code.name() + ": " + detail);
        this.code = Objects.requireNonNull(code, "code");
        this.detail = detail == null ? "" : detail;
    }

    /**
     * Return the exception class that fits the blame of {@code code}.
     *
     * @param code the condition
     * @param detail a human-readable explanation (may be empty)
     * @return a {@link RemoteProtocolException}, {@link PeerException} or
     *     {@link LocalProtocolException} (or one of its subclasses)
     */
    public static OpenAirException of(ErrorCode code, String detail) {
        switch (code) {
            case REQUEST_TIMEOUT:
                return new RequestTimeoutException(detail);
            case CONNECTION_CLOSED:
                return new ConnectionClosedException(detail);
            case API_MISUSE:
                return new ApiMisuseException(detail);
            default:
                break;
        }
        switch (code.blame()) {
            case REMOTE:
                return new RemoteProtocolException(code, detail);
            case PEER:
                return new PeerException(code, detail);
            default:
                return new LocalProtocolException(code, detail);
        }
    }

    /** @return the condition of the error table */
    public ErrorCode code() {
        return code;
    }

    /** @return the human-readable detail (possibly empty) */
    public String detail() {
        return detail;
    }

    /**
     * Return the text a RECEIVE_ERROR carries for this condition: {@code NAME: detail}, or just
     * {@code NAME} when the detail is empty (OA-ERR-2).
     *
     * @return the wire text
     */
    public String wireText() {
        return getMessage();
    }
}
