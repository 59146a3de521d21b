package org.openair;

import java.util.Objects;

/**
 * One trigger of a registration (spec 8.4): a type pattern (section 5), the whiteboard it watches
 * and the wakeup delay.
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param pattern the type pattern (validated when the registration is sent, OA-MATCH-7)
 * @param whiteboard the whiteboard's name, or "" for every whiteboard (OA-TRIG-2)
 * @param afterMs the wakeup delay in milliseconds (OA-TRIG-3), not negative
 */
public record Trigger(String pattern, String whiteboard, long afterMs) {

    /*
     * Check the fields.
     *
     * @throws ApiMisuseException for a negative delay
     */
    public Trigger {
        Objects.requireNonNull(pattern, "pattern");
        whiteboard = Objects.requireNonNullElse(whiteboard, "");
        if (afterMs < 0) {
            throw new ApiMisuseException("trigger after must not be negative: " + afterMs);
        }
    }

    /**
     * A trigger on every whiteboard, without delay.
     *
     * @param pattern the type pattern
     * @return the trigger
     */
    public static Trigger on(String pattern) {
        return new Trigger(pattern, "", 0);
    }

    /**
     * A trigger on one whiteboard, without delay.
     *
     * @param whiteboard the whiteboard
     * @param pattern the type pattern
     * @return the trigger
     */
    public static Trigger on(String whiteboard, String pattern) {
        return new Trigger(pattern, whiteboard, 0);
    }
}
