package org.openair;

/**
 * A sample pushed to this client: by a push subscription (spec 11.6, OA-STREAM-8) or through the
 * module's registration ({@code <inputstream>}, OA-STREAM-14).
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param stream the stream's name (the {@code from} of the DATASAMPLE)
 * @param sample the sample
 * @param dropped how many samples the server dropped for this subscriber since the previous one
 *     it sent (the {@code dropped} slot, OA-STREAM-8)
 * @param receivedNanos wall-clock Unix nanoseconds read when its bytes arrived
 */
public record ReceivedSample(String stream, DataSample sample, long dropped, long receivedNanos) {}
