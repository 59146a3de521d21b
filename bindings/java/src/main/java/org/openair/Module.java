package org.openair;

import java.time.Duration;
import java.util.List;
import java.util.Optional;
import java.util.Set;
import java.util.concurrent.CompletableFuture;

/**
 * A connected OpenAIR module (or, with {@code bind=false}, a plain client). Obtain one with
 * {@link OpenAir#connect(Options)}; close it when done.
 *
 * <p>Requests travel on the module's primary connection. Towards a legacy server one request is in
 * flight at a time (OA-SESS-18); when the server advertises {@code pipelining}, up to its
 * {@code max-in-flight} requests are (OA-SESS-17). Replies are paired with requests in order
 * (OA-SESS-33). A failure reply raises {@link RequestFailedException}; no reply within the request
 * timeout raises {@link RequestTimeoutException} and closes the primary connection (OA-SESS-27),
 * after which the module reconnects if its options say so and re-sends its registration.
 *
 * <p>Threading: every method is thread-safe. The blocking methods block the calling thread only;
 * they may be called from a {@link WakeupListener} (on the dispatcher thread). The module runs
 * these threads, all daemons named {@code openair-<name>-…}: one reader per connection (primary,
 * callback, and each connection the server opens to the listening port), one acceptor for the
 * listening port, one maintenance thread (reconnection, KEEPALIVE) and one dispatcher thread,
 * which alone calls the listeners of {@link Options}. Stream handles add a reader per stream
 * connection, and push subscriptions one reader (and, with a listener or Flow subscriber, one
 * delivery thread) each; see {@link StreamHandle}.
 */
public interface Module extends AutoCloseable {

    /** @return the module's name */
    String name();

    /** @return the port of BIND_ACCEPT, or -1 (BIND_NOLISTEN, or not bound) */
    int boundPort();

    /** @return the local port deliveries are accepted on, or -1 when the module does not listen */
    int listenPort();

    /** @return true when the server answered GET_CAPABILITIES with anything else (OA-CAP-2) */
    boolean legacy();

    /** @return what the server advertised, or empty for a legacy server */
    Optional<Capabilities> capabilities();

    /** @return the extensions in use: declared by this module and advertised by the server */
    Set<String> extensions();

    /** @return true while the primary connection is up and set up */
    boolean isConnected();

    /** @return how many times the module has connected (1 after connect, +1 per reconnection) */
    int generation();

    /**
     * Deliveries that could not be read (their frame, envelope or wakeup content): each was
     * answered RECEIVE_ERROR, logged with its reason (WARNING on {@code org.openair}), reported
     * to the connection listener's {@code onError} and lost (OA-MSG-20).
     *
     * @return how many deliveries could not be read
     */
    long undecodableDeliveries();

    /**
     * Deliveries lost: those of {@link #undecodableDeliveries()} plus direct messages dropped
     * because the inbox was full and nobody read it.
     *
     * @return how many deliveries were lost
     */
    long droppedMessages();

    /**
     * Post text content and wait for RECEIVE_ACCEPT (OA-WB-3).
     *
     * @param to the whiteboard (or module) addressed
     * @param type the message type (validated, OA-TYPE-1)
     * @param content the text content
     * @return the message as sent, with its id and postedTime
     * @throws RequestFailedException when the server refuses it
     */
    Message post(String to, String type, String content);

    /**
     * Post a message built by the caller and wait for RECEIVE_ACCEPT. An empty {@code from} is
     * filled with the module's name; postedTime is stamped when it is sent (OA-TIME-2).
     *
     * @param message the message
     * @return the message as sent
     * @throws RequestFailedException when the server refuses it
     */
    Message post(Message message);

    /**
     * Post without waiting for the reply; the future completes with the message as sent once it
     * is acknowledged. Several calls are pipelined when the server advertises {@code pipelining};
     * the call itself blocks only while the window of requests in flight is full. The future
     * completes on a {@link java.util.concurrent.ForkJoinPool#commonPool()} thread, never on one
     * of the library's threads.
     *
     * @param message the message
     * @return the future
     */
    CompletableFuture<Message> postAsync(Message message);

    /**
     * Post several messages in order, pipelined when the server allows (OA-SESS-17), and wait for
     * every acknowledgement. The first failure is thrown after all replies arrived.
     *
     * @param messages the messages
     * @return the messages as sent
     */
    List<Message> postAll(List<Message> messages);

    /**
     * Post without waiting for an acknowledgement: with {@code noreply="yes"} when the server
     * advertised {@code noreply} (OA-MSG-15), otherwise as an ordinary post whose reply is read
     * and dropped (OA-GEN-2).
     *
     * @param message the message
     * @return the message as sent
     */
    Message postNoReply(Message message);

    /**
     * Replace the module's registration (AIR.Subscribe to AIRCentral, OA-REG-1); it is re-sent
     * after every reconnection. Patterns are validated first (OA-MATCH-7).
     *
     * @param registration the triggers and retrieves
     */
    void subscribe(Registration registration);

    /**
     * Retrieve stored messages with one spec (AIR.Retrieve to AIRCentral), newest first.
     *
     * @param spec the criteria
     * @return the stored copies
     */
    List<Message> retrieve(RetrieveSpec spec);

    /**
     * Retrieve with one spec (AIR.Retrieve) or several (AIR.Retrieves), sent to {@code to}.
     *
     * @param specs the criteria (at least one)
     * @param to the whiteboard addressed (read when a spec names none, OA-RET-2)
     * @return the stored copies, each retrieve's results newest first, retrieves in order
     */
    List<Message> retrieve(List<RetrieveSpec> specs, String to);

    /**
     * Send any request as it is (postedTime stamped) and return the reply, uninterpreted.
     *
     * @param request the request
     * @return the reply
     */
    Message request(Message request);

    /**
     * Send PING to CNS and measure the round trip (OA-SESS-10).
     *
     * @return the round-trip time
     */
    Duration ping();

    /**
     * Wait for the next wakeup. Only when no {@link WakeupListener} is set.
     *
     * @param timeout how long to wait
     * @return the wakeup, or empty after the timeout or once the module is closed
     * @throws ApiMisuseException when a wakeup listener is set
     */
    Optional<Wakeup> nextWakeup(Duration timeout);

    /**
     * Wait for the next forwarded message. Only when no {@link MessageListener} is set.
     *
     * @param timeout how long to wait
     * @return the delivery, or empty after the timeout or once the module is closed
     * @throws ApiMisuseException when a message listener is set
     */
    Optional<Delivery> nextMessage(Duration timeout);

    /**
     * Return the handle of the stream named (or, under {@code typed-streams}, typed)
     * {@code target}; one handle per target, closed with the module (spec section 11). Its
     * connections open on first use.
     *
     * @param target the stream's name or type
     * @return the handle
     */
    StreamHandle stream(String target);

    /**
     * Ask CNS for every stream (GET_STREAMS, OA-STREAM-16).
     *
     * @return the streams, in the server's order
     * @throws RequestFailedException when the server does not know GET_STREAMS (a legacy one)
     */
    List<StreamInfo> listStreams();

    /**
     * Receive stream alarms (OA-XSTREAM-6) through a companion module whose trigger is
     * {@code pattern} (for example {@code AIR.Stream.Alarm.*}); closed with the module.
     *
     * @param pattern the alarm type pattern
     * @param whiteboard the whiteboard the alarms are posted to, or "" for any
     * @return the subscription
     */
    AlarmSubscription alarms(String pattern, String whiteboard);

    /**
     * Wait for the next sample of a stream the module's registration subscribes to
     * ({@link Registration#inputStreams()}, OA-STREAM-14). The samples come as deliveries; each
     * is acknowledged once it is queued here (the queue holds {@code inboxSize}).
     *
     * @param timeout how long to wait
     * @return the sample, or empty after the timeout or once the module is closed
     */
    Optional<ReceivedSample> nextSample(Duration timeout);

    /** Close every connection and stop every thread; later requests throw CONNECTION_CLOSED. */
    @Override
    void close();
}
