package org.openair;

import java.nio.ByteBuffer;
import java.time.Duration;
import java.util.List;
import java.util.Map;
import java.util.Optional;
import java.util.concurrent.CompletableFuture;
import java.util.concurrent.Flow;

/**
 * One stream, by name or (extension {@code typed-streams}) by type, as seen from a module: get it
 * with {@link Module#stream(String)} (spec section 11).
 *
 * <p>The handle talks to the stream over a connection of its own, opened on first use with
 * {@code GET_NAME}, so that the connection's current stream is always this stream
 * (OA-STREAM-11). A waiting command blocks its connection until its reply (OA-SESS-2), so each
 * wait runs on a further connection taken from a small pool. Locks belong to the handle's
 * connection (OA-XSTREAM-5). A failure reply raises {@link RequestFailedException}, whose
 * {@link RequestFailedException#condition()} names the condition (SAMPLE_UNKNOWN,
 * STREAM_UNKNOWN, SAMPLE_INVALID, LOCK_UNKNOWN, …).
 *
 * <p>Payloads are not copied: a sample is written from the caller's buffer straight to the
 * socket, and a sample read is a read-only view of the received chunk. Do not change a payload's
 * buffer while the call that writes it runs.
 *
 * <p>Threading: thread-safe; every method blocks the calling thread only. Requests on the
 * handle's connection are pipelined within the server's window; waits run on their own
 * connections, so a wait never holds up other calls. Closing the module closes its handles.
 */
public interface StreamHandle extends AutoCloseable {

    /** @return the name or type the handle was made for */
    String target();

    /**
     * Return the stream's name (its type resolved, for a handle made from a type).
     *
     * @return the name the stream answered GET_NAME with
     */
    String name();

    // ------------------------------------------------------------------------- writing

    /**
     * Add one sample (ADD_SAMPLE) and return its id (OA-STREAM-5).
     *
     * @param sample the sample; {@code builtin:id} and {@code builtin:timestamp} may be set by
     *     the stream (OA-STREAM-4)
     * @return the new id
     */
    long add(DataSample sample);

    /**
     * Add one sample of {@code payload} with {@code params} (ADD_SAMPLE).
     *
     * @param payload the payload (viewed, not copied)
     * @param params parameters in iteration order (may be empty)
     * @return the new id
     */
    default long add(ByteBuffer payload, Map<String, String> params) {
        return add(DataSample.of(payload).withParams(params));
    }

    /**
     * Add several samples in one ADD_SAMPLES: all or none are added (OA-STREAM-5).
     *
     * @param samples at least one
     * @return their ids, in order
     */
    List<Long> addAll(List<DataSample> samples);

    /**
     * Write one sample now and return the future of its id without waiting for the reply;
     * successive calls are pipelined within the server's window (OA-SESS-17) and answered in
     * order. With {@code binary} the sample goes as a bare {@code BinaryM} frame
     * (OA-STREAM-11), else as ADD_SAMPLE. The future completes on a
     * {@link java.util.concurrent.ForkJoinPool#commonPool()} thread.
     *
     * @param sample the sample
     * @param binary send a BinaryM frame
     * @return the future id
     */
    CompletableFuture<Long> submit(DataSample sample, boolean binary);

    /**
     * Add many samples pipelined (one ADD_SAMPLE each, up to the window in flight) and wait for
     * every id; the first failure is thrown after all replies arrived.
     *
     * @param samples the samples
     * @return their ids, in order
     */
    List<Long> addPipelined(List<DataSample> samples);

    /**
     * Add one sample without waiting for its reply: with {@code noreply="yes"} when the server
     * advertised {@code noreply} (OA-MSG-15), else as an ordinary ADD_SAMPLE whose reply is
     * read and dropped (OA-GEN-2).
     *
     * @param sample the sample
     */
    void addNoReply(DataSample sample);

    // ------------------------------------------------------------------------- reading

    /**
     * GET_SAMPLE_BY_ID.
     *
     * @param id the sample id
     * @return the sample
     * @throws RequestFailedException SAMPLE_UNKNOWN when the stream does not hold it
     */
    DataSample get(long id);

    /**
     * GET_SAMPLE_BY_TIME: the sample with the greatest timestamp at or before {@code ms}.
     *
     * @param ms ms since the epoch
     * @return the sample
     */
    DataSample at(long ms);

    /**
     * GET_SAMPLES_BY_TIME: the samples timestamped within [{@code fromMs}, {@code untilMs}].
     *
     * @param fromMs ms since the epoch
     * @param untilMs ms since the epoch
     * @return the samples, oldest first
     */
    List<DataSample> between(long fromMs, long untilMs);

    /** @return the newest sample (GET_NEWEST_DATASAMPLE) */
    DataSample newest();

    /** @return the oldest sample held (GET_OLDEST_DATASAMPLE) */
    DataSample oldest();

    /** @return the newest sample's timestamp, ms since the epoch */
    long newestTimestamp();

    /** @return the oldest held sample's timestamp, ms since the epoch */
    long oldestTimestamp();

    /** @return how many samples the stream holds (GET_COUNT) */
    long count();

    /** @return the payload bytes the stream holds (GET_SIZE) */
    long size();

    /** @return the stream's {@code <streaminfo>} (GET_INFO) */
    StreamInfo info();

    /**
     * SEARCH_SAMPLES (OA-XSTREAM-9, extension {@code typed-streams}).
     *
     * @param afterMs lower time bound (inclusive), or null
     * @param untilMs upper time bound (inclusive), or null
     * @param params parameter key → glob (OA-RET-8); all must match
     * @param latest at most the newest this many, 0 for all
     * @return the samples, oldest first
     * @throws ApiMisuseException when the server does not advertise typed-streams (OA-GEN-2)
     */
    List<DataSample> search(Long afterMs, Long untilMs, Map<String, String> params, int latest);

    // ------------------------------------------------------------------------- waiting

    /**
     * WAIT_FOR_FIRST_AFTERID / WAIT_FOR_LAST_AFTERID (OA-STREAM-7): the oldest (with
     * {@code last}, the newest) sample with an id greater than {@code id}.
     *
     * @param id the id
     * @param timeout how long the stream waits
     * @param last the newest rather than the oldest
     * @return the sample, or empty when the timeout passed first
     */
    Optional<DataSample> waitAfterId(long id, Duration timeout, boolean last);

    /**
     * WAIT_FOR_FIRST_SAMPLE / WAIT_FOR_LAST_SAMPLE (OA-STREAM-7): a sample timestamped at or
     * after {@code ms}.
     *
     * @param ms ms since the epoch
     * @param timeout how long the stream waits
     * @param last the newest rather than the oldest
     * @return the sample, or empty when the timeout passed first
     */
    Optional<DataSample> waitForSample(long ms, Duration timeout, boolean last);

    // ------------------------------------------------------------------------- locks

    /**
     * LOCK_SAMPLES {@code first-last} (OA-XSTREAM-5, extension {@code typed-streams}).
     *
     * @param first first id
     * @param last last id (not below first)
     * @return the lock; close it to release it
     */
    StreamLock lock(long first, long last);

    /**
     * UNLOCK_SAMPLES a lock id held by this handle's connection.
     *
     * @param lockId the lock id
     * @throws RequestFailedException LOCK_UNKNOWN when the connection does not hold it
     */
    void unlock(long lockId);

    // ------------------------------------------------------------------------- push

    /**
     * Open a push subscription read with {@link StreamSubscription#next}: a connection of its own
     * whose {@code Receive} frame names this stream (OA-STREAM-8); returns once the stream counts
     * the new subscriber (GET_INFO), so no later sample is missed.
     *
     * @param buffer samples held locally before acknowledgements are held back (at least 1)
     * @return the subscription
     */
    StreamSubscription subscribe(int buffer);

    /**
     * Open a push subscription whose samples go to {@code listener} (see {@link SampleListener}
     * for the threading).
     *
     * @param listener the listener
     * @return the subscription
     */
    StreamSubscription subscribe(SampleListener listener);

    /**
     * Return a publisher of this stream's samples: each {@link Flow.Subscriber} gets a push
     * subscription of its own, opened when it subscribes. Demand is honoured: without demand the
     * acknowledgements are held back, so the server drops samples for that subscriber only.
     * {@code onNext}, {@code onError} and {@code onComplete} run on the subscription's delivery
     * thread; cancelling closes the push connection.
     *
     * @return the publisher
     */
    Flow.Publisher<ReceivedSample> publisher();

    /** Close the handle's connections (its locks are released by the server) and subscriptions. */
    @Override
    void close();
}
