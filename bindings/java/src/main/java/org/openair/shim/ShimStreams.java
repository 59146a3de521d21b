package org.openair.shim;

import java.nio.ByteBuffer;
import java.time.Duration;
import java.util.ArrayList;
import java.util.Base64;
import java.util.HashMap;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Optional;
import java.util.function.Supplier;
import org.openair.AlarmSubscription;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.DataSample;
import org.openair.Module;
import org.openair.ReceivedSample;
import org.openair.RequestTimeoutException;
import org.openair.StreamAlarm;
import org.openair.StreamHandle;
import org.openair.StreamInfo;
import org.openair.StreamLock;
import org.openair.StreamSubscription;

/**
 * The stream commands of the Java shim (PROTOCOL.md, "Streams and attachments"): each turns into
 * one call of the library's stream API. Payloads travel as base64, or as {@code {"fill", "size"}}
 * so that a scenario can ask for a sample of several MiB without sending it on the shim's input.
 *
 * <p>Threading: called on the shim's main thread only.
 */
final class ShimStreams {
    private static final int MAX_FILL = 64 * 1024 * 1024;

    private final Supplier<Module> module;
    private final Map<Long, StreamSubscription> subscriptions = new HashMap<>();
    private final Map<Long, AlarmSubscription> alarms = new HashMap<>();
    private final Map<String, Map<Long, StreamLock>> locks = new HashMap<>();
    private long nextHandle = 1;

    ShimStreams(Supplier<Module> module) {
        this.module = module;
    }

    /**
     * Run one stream command.
     *
     * @param name the command
     * @param cmd its fields
     * @return the answer's fields, or null when {@code name} is not a stream command
     */
    Map<String, Object> run(String name, Map<String, Object> cmd) {
        return switch (name) {
            case "stream-open" -> Map.of("name", handle(cmd).name());
            case "stream-add" -> add(cmd);
            case "stream-add-many" -> addMany(cmd);
            case "stream-read" -> read(cmd);
            case "stream-wait" -> waitFor(cmd);
            case "stream-info" -> Map.of("info", info(handle(cmd).info()));
            case "stream-search" -> search(cmd);
            case "stream-lock" -> lock(cmd);
            case "stream-unlock" -> unlock(cmd);
            case "stream-subscribe" -> subscribe(cmd);
            case "stream-next" -> next(cmd);
            case "stream-unsubscribe" -> unsubscribe(cmd);
            case "await-sample" -> awaitSample(cmd);
            case "alarms-subscribe" -> alarmsSubscribe(cmd);
            case "await-alarm" -> awaitAlarm(cmd);
            default -> null;
        };
    }

    /** Close every subscription the shim opened. */
    void close() {
        subscriptions.values().forEach(StreamSubscription::close);
        alarms.values().forEach(AlarmSubscription::close);
        subscriptions.clear();
        alarms.clear();
    }

    // --------------------------------------------------------------------------- values

    static long integer(Map<String, Object> m, String key, Long dflt) {
        Object v = m.get(key);
        if (v == null && dflt != null) {
            return dflt;
        }
        if (v instanceof Number n) {
            return n.longValue();
        }
        if (v instanceof String s && s.matches("-?[0-9]{1,18}")) {
            return Long.parseLong(s);
        }
        throw new ApiMisuseException(key + " must be an integer");
    }

    private static Long optional(Map<String, Object> m, String key) {
        return m.get(key) == null ? null : integer(m, key, null);
    }

    static byte[] base64(Object text) {
        if (!(text instanceof String s)) {
            throw new ApiMisuseException("base64 text expected");
        }
        try {
            return Base64.getDecoder().decode(s);
        } catch (IllegalArgumentException e) {
            throw new ApiMisuseException("not base64: " + e.getMessage());
        }
    }

    @SuppressWarnings("unchecked")
    static byte[] payload(Object spec) {
        if (spec instanceof Map<?, ?> m) {
            Map<String, Object> fill = (Map<String, Object>) m;
            byte[] unit = base64(fill.getOrDefault("fill", ""));
            long size = integer(fill, "size", null);
            if (size < 0 || size > MAX_FILL) {
                throw new ApiMisuseException("a fill size must be an integer in 0.." + MAX_FILL);
            }
            if (size > 0 && unit.length == 0) {
                throw new ApiMisuseException("a fill needs at least one byte");
            }
            byte[] out = new byte[(int) size];
            for (int at = 0; at < out.length; at += unit.length) {
                System.arraycopy(unit, 0, out, at, Math.min(unit.length, out.length - at));
            }
            return out;
        }
        return base64(spec == null ? "" : spec);
    }

    /** The sample a row describes: the writer's params first, then timestamp and seq. */
    @SuppressWarnings("unchecked")
    private static DataSample sample(Map<String, Object> row) {
        Map<String, String> params = new LinkedHashMap<>();
        Object raw = row.get("params");
        if (raw != null) {
            if (!(raw instanceof List<?> pairs)) {
                throw new ApiMisuseException("params must be a list of [key, value] pairs");
            }
            for (Object p : pairs) {
                if (!(p instanceof List<?> kv) || kv.size() != 2) {
                    throw new ApiMisuseException("params must be a list of [key, value] pairs");
                }
                params.put(String.valueOf(kv.get(0)), String.valueOf(kv.get(1)));
            }
        }
        Long stamp = optional(row, "timestamp_ms");
        if (stamp != null) {
            if (stamp < 0) {
                throw new ApiMisuseException("a timestamp must not be negative: " + stamp);
            }
            params.put(DataSample.TIMESTAMP, Long.toString(stamp));
        }
        Long seq = optional(row, "sample_seq");
        if (seq != null) {
            params.put(DataSample.SEQ, Long.toString(seq)); // OA-XSTREAM-8
        }
        return DataSample.of(ByteBuffer.wrap(payload(row.get("payload")))).withParams(params);
    }

    private static Object natural(java.util.OptionalLong v) {
        return v.isPresent() && v.getAsLong() >= 0 ? v.getAsLong() : null;
    }

    static Map<String, Object> sampleObject(DataSample s, boolean payloads) {
        Map<String, Object> o = new LinkedHashMap<>();
        o.put("id", natural(s.id()));
        o.put("timestamp", natural(s.timestampMs()));
        o.put("size", (long) s.size());
        o.put("payload", payloads ? Base64.getEncoder().encodeToString(s.payloadBytes()) : null);
        List<Object> params = new ArrayList<>();
        for (DataSample.Param p : s.params()) {
            params.add(List.of(p.key(), p.value()));
        }
        o.put("params", params);
        return o;
    }

    private static Map<String, Object> receivedObject(ReceivedSample r, boolean payloads) {
        Map<String, Object> o = new LinkedHashMap<>();
        o.put("stream", r.stream());
        o.put("sample", sampleObject(r.sample(), payloads));
        o.put("dropped", r.dropped());
        o.put("received_ns", r.receivedNanos());
        return o;
    }

    private static Map<String, Object> info(StreamInfo i) {
        Map<String, Object> o = new LinkedHashMap<>();
        o.put("name", i.name());
        o.put("whiteboard", i.whiteboard());
        o.put("type", i.type());
        o.put("count", i.count());
        o.put("size", i.size());
        o.put("oldest", i.oldest().isPresent() ? i.oldest().getAsLong() : null);
        o.put("newest", i.newest().isPresent() ? i.newest().getAsLong() : null);
        o.put("maxsize", i.maxsize());
        o.put("maxcount", i.maxcount());
        o.put("subscribers", i.subscribers());
        o.put("locked", i.locked());
        return o;
    }

    private static boolean payloads(Map<String, Object> cmd) {
        Object v = cmd.get("payloads");
        return v == null || Boolean.TRUE.equals(v);
    }

    private static Duration timeout(Map<String, Object> cmd) {
        return Duration.ofMillis(Math.max(0, integer(cmd, "timeout_ms", 5000L)));
    }

    private StreamHandle handle(Map<String, Object> cmd) {
        Object target = cmd.get("stream");
        if (!(target instanceof String s) || s.isEmpty()) {
            throw new ApiMisuseException("stream must name a stream or a stream type");
        }
        return module.get().stream(s);
    }

    // ------------------------------------------------------------------------- commands

    private Map<String, Object> add(Map<String, Object> cmd) {
        StreamHandle h = handle(cmd);
        DataSample s = sample(cmd);
        String mode = String.valueOf(cmd.getOrDefault("mode", "message"));
        Map<String, Object> out = new LinkedHashMap<>();
        switch (mode) {
            case "message" -> out.put("sample_id", h.add(s));
            case "binary" -> out.put("sample_id", joined(h.submit(s, true)));
            case "noreply" -> {
                h.addNoReply(s);
                out.put("sample_id", null);
            }
            default -> throw new ApiMisuseException("unknown add mode '" + mode + "'");
        }
        return out;
    }

    private static Long joined(java.util.concurrent.CompletableFuture<Long> future) {
        try {
            return future.join();
        } catch (java.util.concurrent.CompletionException e) {
            if (e.getCause() instanceof RuntimeException r) {
                throw r;
            }
            throw e;
        }
    }

    @SuppressWarnings("unchecked")
    private Map<String, Object> addMany(Map<String, Object> cmd) {
        StreamHandle h = handle(cmd);
        if (!(cmd.get("samples") instanceof List<?> rows) || rows.isEmpty()) {
            throw new ApiMisuseException("samples must be a non-empty list of sample objects");
        }
        List<DataSample> samples = new ArrayList<>();
        for (Object row : rows) {
            if (!(row instanceof Map<?, ?>)) {
                throw new ApiMisuseException("samples must be a non-empty list of sample objects");
            }
            samples.add(sample((Map<String, Object>) row));
        }
        String mode = String.valueOf(cmd.getOrDefault("mode", "batch"));
        List<Long> ids = switch (mode) {
            case "batch" -> h.addAll(samples);
            case "pipelined" -> h.addPipelined(samples);
            default -> throw new ApiMisuseException("unknown add-many mode '" + mode + "'");
        };
        return Map.of("sample_ids", new ArrayList<Object>(ids));
    }

    private static Map<String, Object> samples(List<DataSample> found, Map<String, Object> cmd) {
        List<Object> out = new ArrayList<>();
        for (DataSample s : found) {
            out.add(sampleObject(s, payloads(cmd)));
        }
        return Map.of("samples", out);
    }

    private Map<String, Object> read(Map<String, Object> cmd) {
        StreamHandle h = handle(cmd);
        String by = String.valueOf(cmd.get("by"));
        List<DataSample> found = switch (by) {
            case "range" -> h.between(integer(cmd, "from_ms", null), integer(cmd, "until_ms", null));
            case "id" -> List.of(h.get(integer(cmd, "id", null)));
            case "time" -> List.of(h.at(integer(cmd, "time_ms", null)));
            case "newest" -> List.of(h.newest());
            case "oldest" -> List.of(h.oldest());
            default -> throw new ApiMisuseException("unknown read '" + by + "'");
        };
        return samples(found, cmd);
    }

    private Map<String, Object> waitFor(Map<String, Object> cmd) {
        StreamHandle h = handle(cmd);
        boolean last = Boolean.TRUE.equals(cmd.get("last"));
        Long afterId = optional(cmd, "after_id");
        Long afterMs = optional(cmd, "after_ms");
        if ((afterId == null) == (afterMs == null)) {
            throw new ApiMisuseException("stream-wait takes exactly one of after_id and after_ms");
        }
        Optional<DataSample> got = afterId != null ? h.waitAfterId(afterId, timeout(cmd), last)
                : h.waitForSample(afterMs, timeout(cmd), last);
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("sample", got.map(s -> (Object) sampleObject(s, payloads(cmd))).orElse(null));
        return out;
    }

    private Map<String, Object> search(Map<String, Object> cmd) {
        Map<String, String> globs = new LinkedHashMap<>();
        Object raw = cmd.get("params");
        if (raw != null) {
            if (!(raw instanceof Map<?, ?> m)) {
                throw new ApiMisuseException("search params must be an object of key: glob");
            }
            m.forEach((k, v) -> globs.put(String.valueOf(k), String.valueOf(v)));
        }
        List<DataSample> found = handle(cmd).search(optional(cmd, "after_ms"),
                optional(cmd, "until_ms"), globs, (int) integer(cmd, "latest", 0L));
        return samples(found, cmd);
    }

    private Map<String, Object> lock(Map<String, Object> cmd) {
        StreamHandle h = handle(cmd);
        StreamLock lock = h.lock(integer(cmd, "first", null), integer(cmd, "last", null));
        locks.computeIfAbsent(h.target(), t -> new HashMap<>()).put(lock.lockId(), lock);
        return Map.of("lock", lock.lockId());
    }

    private Map<String, Object> unlock(Map<String, Object> cmd) {
        StreamHandle h = handle(cmd);
        long id = integer(cmd, "lock", null);
        Map<Long, StreamLock> held = locks.getOrDefault(h.target(), Map.of());
        StreamLock lock = held.get(id);
        if (lock != null) {
            lock.close(); // through the lock (try-with-resources style), once
            held.remove(id);
        } else {
            h.unlock(id); // an id this shim does not hold: the stream decides (LOCK_UNKNOWN)
        }
        return Map.of();
    }

    private long newHandle() {
        return nextHandle++;
    }

    private Map<String, Object> subscribe(Map<String, Object> cmd) {
        StreamSubscription sub = handle(cmd).subscribe((int) integer(cmd, "buffer", 100L));
        long id = newHandle();
        subscriptions.put(id, sub);
        return Map.of("subscription", id);
    }

    private StreamSubscription subscription(Map<String, Object> cmd) {
        StreamSubscription sub = subscriptions.get(integer(cmd, "subscription", null));
        if (sub == null) {
            throw new ApiMisuseException("no such subscription");
        }
        return sub;
    }

    private Map<String, Object> next(Map<String, Object> cmd) {
        StreamSubscription sub = subscription(cmd);
        Optional<ReceivedSample> got = sub.next(timeout(cmd));
        if (got.isEmpty()) {
            if (!sub.isActive()) {
                throw new ConnectionClosedException("the push connection has ended");
            }
            throw new RequestTimeoutException("no sample within the timeout");
        }
        return Map.of("received", receivedObject(got.get(), payloads(cmd)));
    }

    private Map<String, Object> unsubscribe(Map<String, Object> cmd) {
        StreamSubscription sub = subscription(cmd);
        subscriptions.remove(integer(cmd, "subscription", null));
        sub.close();
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("received", sub.received());
        out.put("dropped", sub.dropped());
        return out;
    }

    private Map<String, Object> awaitSample(Map<String, Object> cmd) {
        Optional<ReceivedSample> got = module.get().nextSample(timeout(cmd));
        if (got.isEmpty()) {
            throw new RequestTimeoutException("no sample within the timeout");
        }
        return Map.of("received", receivedObject(got.get(), payloads(cmd)));
    }

    private Map<String, Object> alarmsSubscribe(Map<String, Object> cmd) {
        Object pattern = cmd.get("pattern");
        String p = pattern == null || pattern.toString().isEmpty() ? "AIR.Stream.Alarm.*"
                : pattern.toString();
        AlarmSubscription sub = module.get().alarms(p,
                String.valueOf(cmd.getOrDefault("whiteboard", "")));
        long id = newHandle();
        alarms.put(id, sub);
        return Map.of("subscription", id);
    }

    private Map<String, Object> awaitAlarm(Map<String, Object> cmd) {
        AlarmSubscription sub = alarms.get(integer(cmd, "subscription", null));
        if (sub == null) {
            throw new ApiMisuseException("no such alarm subscription");
        }
        Optional<StreamAlarm> alarm = sub.next(timeout(cmd));
        if (alarm.isEmpty()) {
            throw new RequestTimeoutException("no alarm within the timeout");
        }
        Map<String, Object> o = new LinkedHashMap<>();
        o.put("kind", alarm.get().kind());
        o.put("stream", alarm.get().stream());
        o.put("entries", new LinkedHashMap<String, Object>(alarm.get().entries()));
        return Map.of("alarm", o);
    }

}
