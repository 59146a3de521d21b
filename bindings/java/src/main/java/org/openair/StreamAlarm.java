package org.openair;

import java.util.Map;

/**
 * An alarm a typed stream posted (OA-XSTREAM-6): {@code AIR.Stream.Alarm.<kind>}.
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param kind {@code Started}, {@code Idle}, {@code SoftLimit}, {@code HardLimit} or {@code Gap}
 * @param stream the stream's name
 * @param entries the content's dictionary ({@code stream}, {@code streamtype}, {@code time} and
 *     the kind's own entries), in document order
 * @param message the alarm post itself
 */
public record StreamAlarm(String kind, String stream, Map<String, String> entries,
        Message message) {
    /* Copy the entries, keeping their order. */
    public StreamAlarm {
        entries = java.util.Collections.unmodifiableMap(new java.util.LinkedHashMap<>(entries));
    }
}
