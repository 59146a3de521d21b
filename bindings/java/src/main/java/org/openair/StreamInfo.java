package org.openair;

import java.util.Map;
import java.util.OptionalLong;

/**
 * One {@code <streaminfo>} (GET_INFO, GET_STREAMS; spec 11.4): sizes in bytes, ids, counts.
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param name the stream's name
 * @param whiteboard the whiteboard that owns it
 * @param type its type, or "" for an untyped stream
 * @param count samples held
 * @param size payload bytes held
 * @param oldest id of the oldest sample held, or empty
 * @param newest id of the newest sample held, or empty
 * @param maxsize byte limit, bytes
 * @param maxcount count limit, 0 for none
 * @param subscribers push connections plus modules subscribed by registration
 * @param writers distinct writers so far
 * @param locked samples held that a lock covers
 * @param attributes every attribute as written, in document order
 */
public record StreamInfo(String name, String whiteboard, String type, long count, long size,
        OptionalLong oldest, OptionalLong newest, long maxsize, long maxcount, long subscribers,
        long writers, long locked, Map<String, String> attributes) {
    /* Copy the attributes. */
    public StreamInfo {
        attributes = Map.copyOf(attributes);
    }
}
