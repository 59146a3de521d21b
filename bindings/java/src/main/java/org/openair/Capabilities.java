package org.openair;

import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Objects;
import java.util.OptionalLong;

/**
 * What a server advertised in its {@code CAPABILITIES} reply (spec 15.1, OA-CAP-1): its
 * protocol, its name and version, the extensions it implements and its limits (spec 14.1).
 *
 * <p>Threading: immutable value; safe to share between threads.
 *
 * @param protocol the protocol, e.g. {@code OpenAIR/1.0}
 * @param server the implementation and its version
 * @param extensions the advertised extension names, in order
 * @param limits the advertised limits by name, in order
 */
public record Capabilities(
        String protocol, String server, List<String> extensions, Map<String, Long> limits) {

    /* Copy the collections (the limits keep their order). */
    public Capabilities {
        Objects.requireNonNull(protocol, "protocol");
        Objects.requireNonNull(server, "server");
        extensions = List.copyOf(extensions);
        limits = java.util.Collections.unmodifiableMap(new LinkedHashMap<>(limits));
    }

    /**
     * Return a limit's value.
     *
     * @param name the limit's name, e.g. {@code max-in-flight}
     * @return the value, or empty when not advertised
     */
    public OptionalLong limit(String name) {
        Long value = limits.get(name);
        return value == null ? OptionalLong.empty() : OptionalLong.of(value);
    }
}
