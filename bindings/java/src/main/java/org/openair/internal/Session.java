package org.openair.internal;

import java.util.ArrayDeque;
import java.util.ArrayList;
import java.util.Deque;
import java.util.EnumMap;
import java.util.List;
import java.util.Map;
import java.util.Set;
import java.util.function.LongSupplier;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.RemoteProtocolException;

/**
 * The client side of one OpenAIR connection, without I/O (h11-style, spec section 6).
 *
 * <p>Calls become bytes to send, received bytes become events. The clock is passed in and read
 * only as the last act before a message is encoded (OA-TIME-2). A connection has a fixed role
 * (OA-SESS-28): as REQUESTER it sends requests and every frame it receives is a {@link Reply},
 * paired with the oldest unanswered request (OA-SESS-33); as RESPONDER (a connection the server
 * opened, or a callback connection after its {@code Receive} frame) every frame is a
 * {@link Request} (or an {@link Invalid} one), answered in arrival order (OA-SESS-2, OA-SESS-11).
 * A remote protocol error is thrown from {@link #receive} and is sticky (OA-FRAME-9).
 *
 * <p>Threading: not thread-safe; the socket adapters guard it with a lock.
 */
public final class Session {
    /** Which side of the request/reply pairing this end is (OA-SESS-28). */
    public enum Role {
        /** The side that sends requests (the side that opened the connection). */
        REQUESTER,
        /** The side that answers them. */
        RESPONDER
    }

    /** The state of the connection. */
    public enum State {
        /** Sending requests, receiving replies. */
        REQUESTER,
        /** Receiving requests, sending answers. */
        RESPONDER,
        /** Closed by either side. */
        CLOSED,
        /** Failed with a remote protocol error (sticky, OA-FRAME-9). */
        ERROR
    }

    private enum Action { SEND_REQUEST, SEND_NOTIFICATION, RECEIVE, ANSWER, PEER_CLOSED, CLOSE, FAIL }

    /** What received bytes produce. */
    public sealed interface Event permits Reply, Request, Invalid, Closed {}

    /**
     * A reply, paired with the request it answers (OA-SESS-33).
     *
     * @param requestId the id of the request answered
     * @param message the reply
     */
    public record Reply(String requestId, Message message) implements Event {}

    /**
     * A request the server sent: a wakeup, PING, KEEPALIVE or forwarded message.
     *
     * @param message the request
     * @param needsAnswer false for a {@code noreply} delivery under that extension (OA-MSG-15)
     */
    public record Request(Message message, boolean needsAnswer) implements Event {}

    /**
     * A correctly framed request whose message could not be read; answer it (OA-ERR-3).
     *
     * @param error why it could not be read
     */
    public record Invalid(OpenAirException error) implements Event {}

    /**
     * The peer closed the connection.
     *
     * @param unanswered the ids of the requests that got no reply
     */
    public record Closed(List<String> unanswered) implements Event {}

    /**
     * Rewrites a frame this end is about to send. A test seam only: see {@link #tap}.
     */
    interface FrameTap {
        /**
         * Return the bytes to send instead of {@code frame} (empty: send nothing).
         *
         * @param message the message the frame carries, as encoded
         * @param tag the frame's tag
         * @param frame the encoded frame
         * @return the bytes to send
         */
        byte[] rewrite(Message message, Frame.Tag tag, byte[] frame);
    }

    /**
     * Test seam, null in every library use: when set, every frame a session builds passes
     * through it before it is sent. Package-private and never assigned by the library or its
     * API; only the deliberately broken conformance shim of the tests (src/test/java:
     * {@code org.openair.internal.FrameFaults}, run by {@code org.openair.shim.BrokenShimMain})
     * sets it, to prove that {@code openair conform-client} catches a misbehaving library.
     */
    static volatile FrameTap tap;

    private static final Map<State, Map<Action, State>> TABLE = table();

    private static Map<State, Map<Action, State>> table() {
        Map<State, Map<Action, State>> t = new EnumMap<>(State.class);
        for (State s : State.values()) {
            t.put(s, new EnumMap<>(Action.class));
        }
        t.get(State.REQUESTER).put(Action.SEND_REQUEST, State.REQUESTER);
        t.get(State.REQUESTER).put(Action.SEND_NOTIFICATION, State.RESPONDER); // OA-SESS-7
        t.get(State.REQUESTER).put(Action.RECEIVE, State.REQUESTER);
        t.get(State.REQUESTER).put(Action.PEER_CLOSED, State.CLOSED);
        t.get(State.REQUESTER).put(Action.CLOSE, State.CLOSED);
        t.get(State.REQUESTER).put(Action.FAIL, State.ERROR);
        t.get(State.RESPONDER).put(Action.RECEIVE, State.RESPONDER);
        t.get(State.RESPONDER).put(Action.ANSWER, State.RESPONDER);
        t.get(State.RESPONDER).put(Action.PEER_CLOSED, State.CLOSED);
        t.get(State.RESPONDER).put(Action.CLOSE, State.CLOSED);
        t.get(State.RESPONDER).put(Action.FAIL, State.ERROR);
        t.get(State.CLOSED).put(Action.RECEIVE, State.CLOSED);
        t.get(State.CLOSED).put(Action.PEER_CLOSED, State.CLOSED);
        t.get(State.CLOSED).put(Action.CLOSE, State.CLOSED);
        t.get(State.ERROR).put(Action.CLOSE, State.ERROR);
        t.get(State.ERROR).put(Action.PEER_CLOSED, State.ERROR);
        return t;
    }

    private final LongSupplier clock;
    private final FrameReader reader;
    private final long maxXml;
    private final int maxDepth;
    private final String name;
    private final Deque<String> inFlight = new ArrayDeque<>();
    private final Deque<Event> toAnswer = new ArrayDeque<>();
    private boolean responder; // this end answers requests (now or before a failure)
    private State state;
    private int window = 1;
    private Set<String> extensions = Set.of();
    private RemoteProtocolException error;
    private Message lastSent;

    /**
     * Create a session.
     *
     * @param role the role of this end
     * @param clock the wall clock, Unix nanoseconds
     * @param name written as {@code from} on answers
     * @param maxXml the XML limit per frame (OA-LIM-1)
     * @param maxBinary the binary limit per frame (OA-LIM-2)
     * @param maxDepth the depth limit (OA-LIM-3)
     */
    public Session(Role role, LongSupplier clock, String name, long maxXml, long maxBinary,
            int maxDepth) {
        this.responder = role == Role.RESPONDER;
        this.state = role == Role.REQUESTER ? State.REQUESTER : State.RESPONDER;
        this.clock = clock;
        this.name = name;
        this.maxXml = maxXml;
        this.maxDepth = maxDepth;
        this.reader = new FrameReader(maxXml, maxBinary, maxDepth);
    }

    /** @return the current state */
    public State state() {
        return state;
    }

    /** @return how many requests were sent and not answered yet */
    public int inFlight() {
        return inFlight.size();
    }

    /** @return true when a request may be sent now without exceeding the window */
    public boolean canSend() {
        return state == State.REQUESTER && inFlight.size() < window;
    }

    /** @return true while bytes of an unfinished frame are held (for OA-FRAME-12) */
    public boolean inFrame() {
        return reader.inFrame();
    }

    /**
     * Set how many requests may be in flight: 1 for a legacy server (OA-SESS-18), up to
     * {@code max-in-flight} under {@code pipelining} (OA-SESS-17).
     *
     * @param window at least 1
     */
    public void window(int window) {
        if (window < 1) {
            throw new ApiMisuseException("window must be at least 1, not " + window);
        }
        this.window = window;
    }

    /** @param extensions the extensions in use on this connection (OA-GEN-2) */
    public void extensions(Set<String> extensions) {
        this.extensions = Set.copyOf(extensions);
    }

    /** @return the last message sent as a request or notification, with its postedTime */
    public Message lastSent() {
        return lastSent;
    }

    private void transition(Action action) {
        State next = TABLE.get(state).get(action);
        if (next == null) {
            if (state == State.CLOSED) {
                throw new ConnectionClosedException("cannot " + action + ": the connection is closed");
            }
            if (state == State.ERROR) {
                throw new ConnectionClosedException("cannot " + action + " after " + error);
            }
            throw new ApiMisuseException("cannot " + action + " in state " + state);
        }
        state = next;
    }

    /** Stamp postedTime from the clock: the last act before encoding (OA-TIME-2, OA-TIME-5). */
    private Message stamp(Message m) {
        AirTime posted = AirTime.ofEpochNanos(clock.getAsLong(), extensions.contains("usec"));
        return m.toBuilder().posted(posted).build();
    }

    /**
     * Return the frame for request {@code msg}, stamped with postedTime.
     *
     * @param msg the request
     * @return the frame bytes
     * @throws ApiMisuseException when the window is full (OA-SESS-18), for noreply without the
     *     extension (OA-GEN-2), or on a responder connection (OA-SESS-28)
     */
    public byte[] sendRequest(Message msg) {
        if (state == State.REQUESTER) {
            if (msg.noreply() && !extensions.contains("noreply")) {
                throw new ApiMisuseException("noreply needs the noreply extension"); // OA-GEN-2
            }
            if (!msg.noreply() && inFlight.size() >= window) {
                throw new ApiMisuseException(window + " request(s) already in flight"); // OA-SESS-18
            }
        }
        transition(Action.SEND_REQUEST);
        Message stamped = stamp(msg);
        byte[] data = frame(stamped, Frame.Tag.MESSAGE);
        lastSent = stamped;
        if (!stamped.noreply()) {
            inFlight.addLast(stamped.id());
        }
        return data;
    }

    /**
     * Return the header and XML of request {@code msg} whose binary chunks, of the sizes given,
     * the caller sends right after these bytes (OA-FRAME-4); {@code msg} itself carries none.
     * Lets a writer send sample payloads from its own buffers, uncopied.
     *
     * @param msg the request, without chunks
     * @param chunkSizes the sizes of the chunks that follow, in order
     * @return the frame's header and XML
     */
    public byte[] sendRequestHead(Message msg, long[] chunkSizes) {
        checkSend(msg);
        transition(Action.SEND_REQUEST);
        Message stamped = stamp(msg);
        byte[] data = new Frame(Frame.Tag.MESSAGE, Codec.encode(stamped, chunkSizes), List.of())
                .encode();
        FrameTap t = tap;
        data = t == null ? data : t.rewrite(stamped, Frame.Tag.MESSAGE, data);
        lastSent = stamped;
        if (!stamped.noreply()) {
            inFlight.addLast(stamped.id());
        }
        return data;
    }

    /**
     * Return the 12-byte header of a {@code BinaryM} frame whose one chunk, of {@code size}
     * bytes, the caller sends next (OA-FRAME-5). It is a request: the stream answers it
     * DATA_ACCEPTED with an empty {@code isresponse} (OA-STREAM-11), paired in order.
     *
     * @param size the chunk's size
     * @return the header
     */
    public byte[] sendBinaryHead(long size) {
        if (size > 0xFFFFFFFFL) {
            throw new ApiMisuseException("a BinaryM chunk of " + size + " bytes is too big");
        }
        if (state == State.REQUESTER && inFlight.size() >= window) {
            throw new ApiMisuseException(window + " request(s) already in flight"); // OA-SESS-18
        }
        transition(Action.SEND_REQUEST);
        byte[] head = new byte[FrameReader.HEADER_SIZE];
        System.arraycopy(Frame.Tag.BINARY.wire().getBytes(java.nio.charset.StandardCharsets
                .US_ASCII), 0, head, 0, 7);
        for (int i = 0; i < 4; i++) {
            head[8 + i] = (byte) (size >>> (8 * i));
        }
        lastSent = Message.builder("BinaryM").id("").build();
        inFlight.addLast(""); // answered with an empty isresponse
        return head;
    }

    private void checkSend(Message msg) {
        if (state == State.REQUESTER) {
            if (msg.noreply() && !extensions.contains("noreply")) {
                throw new ApiMisuseException("noreply needs the noreply extension"); // OA-GEN-2
            }
            if (!msg.noreply() && inFlight.size() >= window) {
                throw new ApiMisuseException(window + " request(s) already in flight"); // OA-SESS-18
            }
        }
    }

    /**
     * Return the {@code Receive} frame that makes this a callback connection (OA-SESS-7); no
     * reply follows, and from then on the server is the requester (OA-SESS-28).
     *
     * @param msg the RECEIVE_NAME_NOTIFICATION
     * @return the frame bytes
     */
    public byte[] sendNotification(Message msg) {
        if (state == State.REQUESTER && !inFlight.isEmpty()) {
            throw new ApiMisuseException("cannot turn a connection with requests in flight around");
        }
        transition(Action.SEND_NOTIFICATION);
        responder = true;
        lastSent = stamp(msg);
        return frame(lastSent, Frame.Tag.RECEIVE);
    }

    private static byte[] frame(Message m, Frame.Tag tag) {
        byte[] data = new Frame(tag, Codec.encode(m), m.binary()).encode();
        FrameTap t = tap;
        return t == null ? data : t.rewrite(m, tag, data);
    }

    /**
     * Return the frame answering {@code request}, which must be the oldest unanswered one
     * (OA-SESS-2). The default type is PING_SUCCESS for PING, KEEPALIVESUCCESS for KEEPALIVE and
     * RECEIVE_ACCEPT otherwise (OA-SESS-11, OA-DELIV-4, OA-KEEP-2); an {@link Invalid} request gets
     * RECEIVE_ERROR with {@code NAME: detail} (OA-ERR-2, OA-ERR-3).
     *
     * @param request the request answered
     * @param type the reply type, or null for the default
     * @param content the reply's text content, or "" for the default
     * @return the frame bytes
     */
    public byte[] answer(Event request, String type, String content) {
        if (state == State.RESPONDER && toAnswer.peekFirst() != request) {
            throw new ApiMisuseException("answer the oldest unanswered request first (OA-SESS-2)");
        }
        transition(Action.ANSWER);
        toAnswer.pollFirst();
        Message reply;
        if (request instanceof Invalid inv) {
            reply = Message.builder(type != null ? type : "RECEIVE_ERROR").sender(name)
                    .content(content.isEmpty() ? inv.error().wireText() : content).build();
        } else {
            Message req = ((Request) request).message();
            String kind = type != null ? type : switch (req.type()) {
                case "PING" -> "PING_SUCCESS";
                case "KEEPALIVE" -> "KEEPALIVESUCCESS";
                default -> "RECEIVE_ACCEPT";
            };
            reply = Message.builder(kind).sender(name).to(req.sender()).isresponse(req.id())
                    .content(content).build(); // OA-SESS-1
        }
        return frame(stamp(reply), Frame.Tag.MESSAGE);
    }

    /**
     * Return the RECEIVE_ERROR a responder sends for a framing error before it closes the
     * connection (OA-FRAME-7), or null when the condition gets no reply (FRAME_UNKNOWN_TAG,
     * FRAME_TRUNCATED) or this end is not the responder. The request's id is unknown, so
     * {@code isresponse} is empty (OA-SESS-1).
     *
     * @param e the framing error
     * @return the frame bytes, or null
     */
    public byte[] framingErrorReply(RemoteProtocolException e) {
        boolean answered = switch (e.code()) {
            case FRAME_TOO_LARGE, BINARY_TOO_LARGE, BINARY_SIZES_INVALID -> true;
            default -> false;
        };
        if (!answered || !responder) {
            return null;
        }
        Message reply = Message.builder("RECEIVE_ERROR").sender(name).content(e.wireText())
                .build();
        return frame(stamp(reply), Frame.Tag.MESSAGE);
    }

    /** Mark the connection closed by this side; later sends throw CONNECTION_CLOSED. */
    public void close() {
        transition(Action.CLOSE);
    }

    /**
     * Feed received bytes and return the events they complete.
     *
     * @param data the bytes
     * @param off where they start
     * @param len how many (0 is allowed and completes nothing)
     * @return the events
     * @throws RemoteProtocolException a framing error or an unreadable reply; sticky
     */
    public List<Event> receive(byte[] data, int off, int len) {
        if (error != null) {
            throw error;
        }
        transition(Action.RECEIVE);
        List<Event> events = new ArrayList<>();
        if (state == State.CLOSED) {
            return events; // closed by this side: late bytes are dropped
        }
        try {
            reader.feed(data, off, len);
            Frame f;
            while ((f = reader.next()) != null) {
                events.add(eventFor(f));
            }
        } catch (RemoteProtocolException e) {
            fail(e);
            throw e;
        }
        return events;
    }

    /**
     * Handle the end of the stream: a partial frame is FRAME_TRUNCATED (OA-FRAME-8).
     *
     * @return the events: frames completed at the end, then {@link Closed}
     */
    public List<Event> receiveEof() {
        if (error != null) {
            throw error;
        }
        List<Event> events = new ArrayList<>();
        if (state == State.CLOSED) {
            return events;
        }
        try {
            reader.feedEof();
            Frame f;
            while ((f = reader.next()) != null) {
                events.add(eventFor(f));
            }
        } catch (RemoteProtocolException e) {
            fail(e);
            throw e;
        }
        List<String> unanswered = List.copyOf(inFlight);
        inFlight.clear();
        transition(Action.PEER_CLOSED);
        events.add(new Closed(unanswered));
        return events;
    }

    private void fail(RemoteProtocolException e) {
        if (state != State.ERROR) {
            transition(Action.FAIL);
        }
        error = e;
    }

    private Message decode(Frame f) {
        if (f.tag() == Frame.Tag.BINARY) {
            throw new RemoteProtocolException(ErrorCode.MESSAGE_INVALID,
                    "a BinaryM frame carries no message");
        }
        // OA-MSG-19: a client reads what a legacy server writes, out-of-range priorities clamped.
        return Codec.decode(f.xml(), f.chunks(), maxXml, maxDepth, true);
    }

    private Event eventFor(Frame f) {
        if (state == State.REQUESTER) {
            return replyFor(decode(f));
        }
        Event event;
        try {
            Message m = decode(f);
            boolean noreply = m.noreply() && extensions.contains("noreply"); // OA-MSG-15
            event = new Request(m, !noreply);
        } catch (RemoteProtocolException e) {
            if (e.code().closes()) {
                throw e;
            }
            event = new Invalid(e); // OA-ERR-3: the connection stays usable
        }
        if (!(event instanceof Request r) || r.needsAnswer()) {
            toAnswer.addLast(event);
        }
        return event;
    }

    private Reply replyFor(Message m) {
        if (inFlight.isEmpty()) {
            throw new RemoteProtocolException(ErrorCode.MESSAGE_INVALID,
                    "reply '" + m.type() + "' with no request in flight");
        }
        String head = inFlight.peekFirst();
        // OA-SESS-33: an empty isresponse is accepted (Psyclone's KEEPALIVESUCCESS); another id
        // means the replies are out of order (OA-SESS-2).
        if (!m.isresponse().isEmpty() && !m.isresponse().equals(head)) {
            throw new RemoteProtocolException(ErrorCode.MESSAGE_INVALID,
                    "reply '" + m.type() + "' answers '" + m.isresponse() + "', expected '" + head
                            + "'");
        }
        inFlight.pollFirst();
        return new Reply(head, m);
    }
}
