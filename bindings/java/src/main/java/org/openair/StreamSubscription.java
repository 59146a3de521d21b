package org.openair;

import java.time.Duration;
import java.util.Optional;

/**
 * A push subscription to one stream (spec 11.6, OA-STREAM-8): its own connection, on which the
 * server sends every new sample and this side acknowledges each once it is in the local buffer.
 *
 * <p>Threading: thread-safe. The connection's reader thread buffers samples; {@link #next} takes
 * them (when the subscription was made without a listener). {@link #close()} ends it; the server
 * also ends it when the connection closes.
 */
public interface StreamSubscription extends AutoCloseable {
    /** @return the stream's name or type the subscription was made for */
    String target();

    /**
     * Take the next sample. Only for a subscription without a listener.
     *
     * @param timeout how long to wait
     * @return the sample, or empty after the timeout or once the subscription has ended
     * @throws ApiMisuseException when the subscription has a listener or publisher
     */
    Optional<ReceivedSample> next(Duration timeout);

    /** @return how many samples arrived */
    long received();

    /** @return the total of the {@code dropped} slots (samples the server dropped for this one) */
    long dropped();

    /** @return true while the push connection is open */
    boolean isActive();

    /** Close the push connection; samples still buffered are dropped. */
    @Override
    void close();
}
