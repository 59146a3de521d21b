package org.openair;

import java.util.List;

/**
 * What a module registers with {@code AIR.Subscribe} (spec 8.1): its triggers, the retrieves whose
 * results come with every wakeup, and whether its own posts may wake it (OA-REG-6). A new
 * registration replaces the previous one as a whole (OA-REG-1); an empty one removes every
 * trigger (OA-REG-11).
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param triggers the triggers, in order
 * @param retrieves the retrieves, in order
 * @param allowSelfTriggering whether the module's own posts may wake it (OA-TRIG-4)
 * @param inputStreams streams subscribed by name, type or type pattern, written as
 *     {@code <inputstream alias="S" source="S"/>}: their samples come as deliveries
 *     ({@link Module#nextSample}, OA-STREAM-14)
 */
public record Registration(
        List<Trigger> triggers, List<RetrieveSpec> retrieves, boolean allowSelfTriggering,
        List<String> inputStreams) {

    /* Copy the lists. */
    public Registration {
        triggers = triggers == null ? List.of() : List.copyOf(triggers);
        retrieves = retrieves == null ? List.of() : List.copyOf(retrieves);
        inputStreams = inputStreams == null ? List.of() : List.copyOf(inputStreams);
    }

    /**
     * A registration without stream subscriptions.
     *
     * @param triggers the triggers, in order
     * @param retrieves the retrieves, in order
     * @param allowSelfTriggering whether the module's own posts may wake it (OA-TRIG-4)
     */
    public Registration(List<Trigger> triggers, List<RetrieveSpec> retrieves,
            boolean allowSelfTriggering) {
        this(triggers, retrieves, allowSelfTriggering, List.of());
    }

    /**
     * A registration of triggers only.
     *
     * @param triggers the triggers
     * @return the registration
     */
    public static Registration of(Trigger... triggers) {
        return new Registration(List.of(triggers), List.of(), false);
    }
}
