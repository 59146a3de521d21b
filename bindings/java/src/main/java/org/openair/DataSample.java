package org.openair;

import java.nio.ByteBuffer;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Objects;
import java.util.Optional;
import java.util.OptionalLong;

/**
 * One stream sample (spec 11.1, 11.2): payload bytes and ordered text parameters.
 *
 * <p>The payload is a read-only {@link ByteBuffer} view: a received sample's payload is a slice of
 * the received chunk (not copied), and a sample built by the caller views the caller's buffer (not
 * copied either; do not change it while a call that writes it runs). Equality compares payload
 * bytes (the remaining bytes of the buffer) and parameters.
 *
 * <p>Threading: immutable value; safe to share between threads (each {@link #payload()} call
 * returns a fresh view, so readers do not share a position).
 *
 * @param payload the payload (read-only view, position 0)
 * @param params the parameters in order; a key normally occurs once, a reader takes the first
 */
public record DataSample(ByteBuffer payload, List<Param> params) {
    /** {@code builtin:id}: the id the stream gave the sample (OA-STREAM-4). */
    public static final String ID = "builtin:id";
    /** {@code builtin:timestamp}: milliseconds since the epoch (OA-STREAM-4). */
    public static final String TIMESTAMP = "builtin:timestamp";
    /** {@code builtin:seq}: the writer's sequence number (OA-XSTREAM-8). */
    public static final String SEQ = "builtin:seq";
    /** {@code builtin:type}. */
    public static final String TYPE = "builtin:type";
    /** {@code builtin:duration}, ms. */
    public static final String DURATION = "builtin:duration";
    /** {@code builtin:name}. */
    public static final String NAME = "builtin:name";

    /**
     * One parameter.
     *
     * @param key the key (not empty)
     * @param value the value
     */
    public record Param(String key, String value) {
        /* Refuse nulls. */
        public Param {
            Objects.requireNonNull(key, "key");
            Objects.requireNonNull(value, "value");
        }
    }

    /* View the payload's remaining bytes (no copy) and copy the parameter list. */
    public DataSample {
        payload = payload == null ? ByteBuffer.allocate(0) : payload.slice();
        params = params == null ? List.of() : List.copyOf(params);
    }

    /**
     * A sample of {@code payload} (viewed, not copied) without parameters.
     *
     * @param payload the payload
     * @return the sample
     */
    public static DataSample of(ByteBuffer payload) {
        return new DataSample(payload, List.of());
    }

    /**
     * A sample of {@code payload} (wrapped, not copied) without parameters.
     *
     * @param payload the payload
     * @return the sample
     */
    public static DataSample of(byte[] payload) {
        return new DataSample(ByteBuffer.wrap(payload), List.of());
    }

    /** @return a fresh read-only view of the payload (position 0); no copy */
    @Override
    public ByteBuffer payload() {
        return payload.asReadOnlyBuffer();
    }

    /**
     * Write the payload to {@code out}: straight from its array when it has one (no copy), else
     * through a bounded buffer.
     *
     * @param out where the bytes go
     * @throws java.io.IOException when writing fails
     */
    public void writePayload(java.io.OutputStream out) throws java.io.IOException {
        ByteBuffer view = payload.duplicate();
        if (view.hasArray()) {
            out.write(view.array(), view.arrayOffset() + view.position(), view.remaining());
            return;
        }
        byte[] piece = new byte[Math.min(65536, view.remaining())];
        while (view.hasRemaining()) {
            int n = Math.min(piece.length, view.remaining());
            view.get(piece, 0, n);
            out.write(piece, 0, n);
        }
    }

    /** @return the payload's size in bytes */
    public int size() {
        return payload.remaining();
    }

    /** @return a copy of the payload bytes */
    public byte[] payloadBytes() {
        byte[] out = new byte[payload.remaining()];
        payload.duplicate().get(out);
        return out;
    }

    /**
     * Return the first value of {@code key}.
     *
     * @param key the key
     * @return the value, or empty
     */
    public Optional<String> param(String key) {
        for (Param p : params) {
            if (p.key().equals(key)) {
                return Optional.of(p.value());
            }
        }
        return Optional.empty();
    }

    private OptionalLong longParam(String key) {
        Optional<String> v = param(key);
        if (v.isEmpty() || !v.get().matches("-?[0-9]{1,18}")) {
            return OptionalLong.empty();
        }
        return OptionalLong.of(Long.parseLong(v.get()));
    }

    /** @return {@code builtin:id} as a number, or empty when absent or not an integer */
    public OptionalLong id() {
        return longParam(ID);
    }

    /** @return {@code builtin:timestamp} (ms since the epoch), or empty */
    public OptionalLong timestampMs() {
        return longParam(TIMESTAMP);
    }

    /** @return {@code builtin:seq}, or empty */
    public OptionalLong seq() {
        return longParam(SEQ);
    }

    /**
     * Return a sample with {@code updates} applied, sharing this payload (no copy): an updated key
     * keeps the place of its first occurrence (later duplicates removed); new keys are appended
     * in the map's iteration order.
     *
     * @param updates the keys to set
     * @return the sample
     */
    public DataSample withParams(Map<String, String> updates) {
        if (updates.isEmpty()) {
            return this;
        }
        Map<String, String> left = new LinkedHashMap<>(updates);
        List<Param> out = new ArrayList<>(params.size() + updates.size());
        java.util.Set<String> done = new java.util.HashSet<>();
        for (Param p : params) {
            if (updates.containsKey(p.key())) {
                if (done.add(p.key())) {
                    out.add(new Param(p.key(), updates.get(p.key())));
                    left.remove(p.key());
                }
            } else {
                out.add(p);
            }
        }
        left.forEach((k, v) -> out.add(new Param(k, v)));
        return new DataSample(payload, out);
    }

    @Override
    public boolean equals(Object o) {
        return o instanceof DataSample s && params.equals(s.params) && payload.equals(s.payload);
    }

    @Override
    public int hashCode() {
        return 31 * payload.hashCode() + params.hashCode();
    }

    @Override
    public String toString() {
        return "DataSample[" + size() + " bytes, params=" + params + "]";
    }
}
