package org.openair;

import java.util.Objects;

/**
 * A {@code <reference>} to another message, as carried by the {@code inreplyto} slot (spec 3.2,
 * OA-MSG-11).
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param id the referenced message's id
 * @param type its type ("" when absent)
 * @param sender its {@code from} ("" when absent)
 * @param to its {@code to} ("" when absent)
 * @param cc its {@code cc} ("" when absent)
 * @param stored its {@code stored} ("" when absent)
 * @param time its time, or {@code null}
 */
public record Reference(
        String id, String type, String sender, String to, String cc, String stored, AirTime time) {

    /* Replace null texts by "" so that an absent attribute reads as empty. */
    public Reference {
        id = Objects.requireNonNullElse(id, "");
        type = Objects.requireNonNullElse(type, "");
        sender = Objects.requireNonNullElse(sender, "");
        to = Objects.requireNonNullElse(to, "");
        cc = Objects.requireNonNullElse(cc, "");
        stored = Objects.requireNonNullElse(stored, "");
    }
}
