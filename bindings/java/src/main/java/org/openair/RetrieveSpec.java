package org.openair;

import java.util.Objects;

/**
 * One {@code <retrieve>} (spec 9.2): the criteria that select stored messages of a whiteboard.
 * Empty strings and {@code null} mean "criterion absent".
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param whiteboard the whiteboard to read ({@code from}, case-sensitive), or "" for the default
 *     (OA-RET-2)
 * @param pattern the type pattern, or "" for every type
 * @param id the id to select exactly, or ""
 * @param sender the {@code from} to select exactly, or ""
 * @param content a content glob (OA-RET-8), or ""
 * @param latest at most this many messages, newest first; 0 means no limit (OA-RET-4)
 * @param lastmsec only messages received within this many ms, or {@code null} (OA-RET-5)
 * @param afterTime inclusive lower bound on receivedTime, or {@code null} (OA-RET-9)
 * @param untilTime inclusive upper bound on receivedTime, or {@code null} (OA-RET-9)
 */
public record RetrieveSpec(
        String whiteboard,
        String pattern,
        String id,
        String sender,
        String content,
        int latest,
        Long lastmsec,
        AirTime afterTime,
        AirTime untilTime) {

    /*
     * Check the counts.
     *
     * @throws ApiMisuseException for a negative latest or lastmsec
     */
    public RetrieveSpec {
        whiteboard = Objects.requireNonNullElse(whiteboard, "");
        pattern = Objects.requireNonNullElse(pattern, "");
        id = Objects.requireNonNullElse(id, "");
        sender = Objects.requireNonNullElse(sender, "");
        content = Objects.requireNonNullElse(content, "");
        if (latest < 0) {
            throw new ApiMisuseException("retrieve latest must not be negative: " + latest);
        }
        if (lastmsec != null && lastmsec < 0) {
            throw new ApiMisuseException("retrieve lastmsec must not be negative: " + lastmsec);
        }
    }

    /**
     * The newest {@code latest} messages of {@code whiteboard} whose type matches {@code pattern}.
     *
     * @param whiteboard the whiteboard ("" for the default)
     * @param pattern the type pattern ("" for every type)
     * @param latest how many (0 for all)
     * @return the spec
     */
    public static RetrieveSpec of(String whiteboard, String pattern, int latest) {
        return new RetrieveSpec(whiteboard, pattern, "", "", "", latest, null, null, null);
    }
}
