package org.openair;

import java.util.Objects;
import java.util.Optional;

/**
 * A request was answered with a failure reply (REQUEST_FAILED, OA-GEN-3): {@code RECEIVE_ERROR},
 * {@code BIND_ERROR}, {@code AIR.Retrieve.Failed}, {@code UNKNOWN_COMMAND} and the like. The
 * request as sent and the reply are kept; {@link #condition()} names the error condition the
 * reply's {@code NAME: detail} content carries, if it names one a peer may send (OA-ERR-2,
 * OA-ERR-8).
 *
 * <p>Threading: immutable; may be passed between threads.
 */
public class RequestFailedException extends PeerException {
    private static final long serialVersionUID = 1L;

    /** The request as sent. */
    private final transient Message request;
    /** The failure reply. */
    private final transient Message reply;

    /**
     * Create the error.
     *
     * @param request the request as sent
     * @param reply the failure reply
     */
    public RequestFailedException(Message request, Message reply) {
        super(ErrorCode.REQUEST_FAILED, describe(request, reply));
        this.request = Objects.requireNonNull(request, "request");
        this.reply = Objects.requireNonNull(reply, "reply");
    }

    private static String describe(Message request, Message reply) {
        String head = request.type() + " answered " + reply.type();
        return reply.content().isEmpty() ? head : head + ": " + reply.content();
    }

    /** @return the request as it was sent (with its postedTime) */
    public Message request() {
        return request;
    }

    /** @return the failure reply */
    public Message reply() {
        return reply;
    }

    /**
     * Return the condition named by the reply's content ({@code NAME: detail}, OA-ERR-2).
     *
     * @return the condition, or empty when the content names none, or names a local one
     *     (OA-ERR-7, OA-ERR-8)
     */
    public Optional<ErrorCode> condition() {
        String name = reply.content().split(":", 2)[0].strip();
        ErrorCode code = ErrorCode.byName(name);
        if (code == null || code.blame() == ErrorCode.Blame.LOCAL) {
            return Optional.empty();
        }
        return Optional.of(code);
    }
}
