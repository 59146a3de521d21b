package org.openair;

/**
 * Receives the samples of a push subscription ({@link StreamHandle#subscribe(SampleListener)}).
 *
 * <p>Threading: called on the subscription's own delivery thread, one sample at a time, in arrival
 * order. While it runs, later samples wait in the subscription's buffer; once that is full the
 * acknowledgements are held back and the server drops samples for this subscriber only
 * (OA-STREAM-8), reported in {@link ReceivedSample#dropped()}.
 */
@FunctionalInterface
public interface SampleListener {
    /**
     * Handle one sample.
     *
     * @param sample the sample
     */
    void onSample(ReceivedSample sample);
}
