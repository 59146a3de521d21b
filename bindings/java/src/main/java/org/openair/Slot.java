package org.openair;

import java.util.Objects;

/**
 * A slot this library does not know, kept verbatim (OA-MSG-5): its name as written and its text,
 * or its inner XML when it holds elements.
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param name the element name, as written
 * @param value the text, or the serialized inner XML when {@code xml} is true
 * @param xml whether {@code value} is inner XML
 */
public record Slot(String name, String value, boolean xml) {

    /* Require a name; a null value reads as "". */
    public Slot {
        Objects.requireNonNull(name, "name");
        value = Objects.requireNonNullElse(value, "");
    }

    /**
     * Build a text slot.
     *
     * @param name the element name
     * @param value its text
     * @return the slot
     */
    public static Slot text(String name, String value) {
        return new Slot(name, value, false);
    }
}
