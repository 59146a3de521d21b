package org.openair;

import java.util.List;
import java.util.Objects;

/**
 * A wakeup delivered to the module ({@code AIR.Instruct.Wakeup}, spec 8.7), taken apart.
 *
 * <p>A phase update (spec 8.8) has no trigger message: {@link #isPhaseUpdate()} is then true
 * (OA-WAKE-8). The library acknowledged the wakeup before handing it over (OA-DELIV-4).
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param message the {@code AIR.Instruct.Wakeup} message itself
 * @param trigger the stored copy that triggered it, or {@code null} for a phase update
 * @param retrieved the results of the registration's retrieves (OA-WAKE-3)
 * @param lasttrigger the pattern of the trigger that fired; "" when woken only by cc (OA-WAKE-4)
 * @param phase the name of the phase in force ("" when the wakeup carries none)
 * @param receivedNanos when the library read the delivery (Unix nanoseconds)
 * @param path the connection that carried it
 */
public record Wakeup(
        Message message,
        Message trigger,
        List<Message> retrieved,
        String lasttrigger,
        String phase,
        long receivedNanos,
        DeliveryPath path) {

    /* Copy the list; null texts read as "". */
    public Wakeup {
        Objects.requireNonNull(message, "message");
        retrieved = retrieved == null ? List.of() : List.copyOf(retrieved);
        lasttrigger = Objects.requireNonNullElse(lasttrigger, "");
        phase = Objects.requireNonNullElse(phase, "");
        Objects.requireNonNull(path, "path");
    }

    /** @return true for a phase update: a wakeup without a trigger message (OA-WAKE-8) */
    public boolean isPhaseUpdate() {
        return trigger == null;
    }
}
