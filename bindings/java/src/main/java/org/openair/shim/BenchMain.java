package org.openair.shim;

import java.nio.ByteBuffer;
import java.nio.charset.StandardCharsets;
import java.time.Duration;
import java.util.ArrayList;
import java.util.Collections;
import java.util.List;
import java.util.Locale;
import java.util.Map;
import java.util.Optional;
import org.openair.AirTime;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;
import org.openair.ReceivedSample;
import org.openair.StreamHandle;
import org.openair.StreamSubscription;
import org.openair.internal.Codec;

/**
 * The Java client's side of {@code bench/bench_bindings.py}; not part of the library's API (the
 * package {@code org.openair.shim} is not exported) and never run by the tests.
 *
 * <p>{@code java -cp target/openair-shim.jar org.openair.shim.BenchMain post HOST PORT N SIZE}
 * binds {@code BenchJava} with BIND_NOLISTEN, requires the server to advertise {@code noreply},
 * sends N noreply posts whose XML is about SIZE bytes, then one PING (answered in order,
 * OA-SESS-2: the server has read every post), and prints
 * {@code {"posts": N, "seconds": S, "send_seconds": T}}: S from the first post to the PING reply,
 * T until the last post was handed to the library. Exit status 0 on success, 2 on an error.
 *
 * <p>{@code ... BenchMain stream HOST PORT STREAM SIZE RATE N} subscribes to STREAM (push), then
 * writes N samples of SIZE bytes at RATE per second, each carrying its wall-clock send time in the
 * parameter {@code bench:ns}, receives them on the push subscription and prints
 * {@code {"sent", "received", "dropped", "p50_ms", "p99_ms", "cpu_s", "seconds"}}, the same line
 * as the C++ and Python stream modes ({@code bench/bench_bindings_streams.py}).
 *
 * <p>Threading: the posts and samples are sent from the main thread; the library's threads read
 * replies and pushed samples.
 */
public final class BenchMain {
    private static final String TYPE = "Bench.Flow.Data";
    private static final String WHITEBOARD = "WB1";
    private static final String NAME = "BenchJava";

    private BenchMain() {}

    /**
     * Run one benchmark mode.
     *
     * @param args {@code post HOST PORT N SIZE}
     */
    public static void main(String[] args) {
        boolean isPost = args.length == 5 && args[0].equals("post");
        boolean isStream = args.length == 7 && args[0].equals("stream");
        if (!isPost && !isStream) {
            System.err.println("usage: BenchMain post HOST PORT N SIZE"
                    + " | BenchMain stream HOST PORT STREAM SIZE RATE N");
            System.exit(2);
        }
        try {
            if (isPost) {
                post(args[1], Integer.parseInt(args[2]), Integer.parseInt(args[3]),
                        Integer.parseInt(args[4]));
            } else {
                stream(args[1], Integer.parseInt(args[2]), args[3], Integer.parseInt(args[4]),
                        Double.parseDouble(args[5]), Integer.parseInt(args[6]));
            }
        } catch (RuntimeException e) {
            System.err.println("BenchMain: " + e);
            System.exit(2);
        }
    }

    private static void post(String host, int port, int n, int size) {
        Options options = Options.builder(NAME).server(host, port).listen(false).announce(false)
                .reconnect(false).build();
        try (Module module = OpenAir.connect(options)) {
            boolean advertised = module.capabilities()
                    .map(c -> c.extensions().contains("noreply")).orElse(false);
            if (!advertised || !module.extensions().contains("noreply")) {
                throw new IllegalStateException("the server does not advertise noreply");
            }
            String content = padding(size);
            long start = System.nanoTime();
            for (int i = 0; i < n; i++) {
                module.postNoReply(Message.builder(TYPE).to(WHITEBOARD).content(content).build());
            }
            double sending = (System.nanoTime() - start) / 1e9;
            Message pong = module.request(Message.builder("PING").sender(NAME).to("CNS").build());
            double seconds = (System.nanoTime() - start) / 1e9;
            if (!pong.type().equals("PING_SUCCESS")) {
                throw new IllegalStateException("PING answered " + pong.type());
            }
            System.out.println(String.format(Locale.ROOT,
                    "{\"posts\": %d, \"seconds\": %.6f, \"send_seconds\": %.6f}",
                    n, seconds, sending));
        }
    }

    private static void stream(String host, int port, String target, int size, double rate,
            int n) {
        Options options = Options.builder("BenchJavaStream").server(host, port).bind(false)
                .announce(false).reconnect(false).build();
        List<Double> latencies = new ArrayList<>();
        long[] dropped = {0};
        try (Module module = OpenAir.connect(options)) {
            StreamHandle handle = module.stream(target);
            StreamSubscription sub = handle.subscribe(Math.max(16, n));
            byte[] payload = new byte[size];
            java.util.Arrays.fill(payload, (byte) 0x5A);
            long cpu0 = cpuNanos();
            long start = System.nanoTime();
            long period = (long) (1e9 / rate);
            for (int i = 0; i < n; i++) {
                long due = start + period * i;
                for (long left = due - System.nanoTime(); left > 0;
                        left = due - System.nanoTime()) {
                    take(sub.next(Duration.ofNanos(Math.max(left, 1_000_000L))), latencies,
                            dropped);
                }
                long sentNs = wallNanos();
                handle.add(ByteBuffer.wrap(payload), Map.of("bench:ns", Long.toString(sentNs)));
            }
            long drainUntil = System.nanoTime() + 5_000_000_000L;
            while (latencies.size() + dropped[0] < n && System.nanoTime() < drainUntil) {
                take(sub.next(Duration.ofMillis(100)), latencies, dropped);
            }
            double seconds = (System.nanoTime() - start) / 1e9;
            double cpu = (cpuNanos() - cpu0) / 1e9;
            Collections.sort(latencies);
            System.out.println(String.format(Locale.ROOT,
                    "{\"sent\": %d, \"received\": %d, \"dropped\": %d, \"p50_ms\": %.6f, "
                            + "\"p99_ms\": %.6f, \"cpu_s\": %.6f, \"seconds\": %.6f}",
                    n, latencies.size(), dropped[0], percentile(latencies, 0.5),
                    percentile(latencies, 0.99), cpu, seconds));
        }
    }

    private static void take(Optional<ReceivedSample> got, List<Double> latencies,
            long[] dropped) {
        if (got.isEmpty()) {
            return;
        }
        ReceivedSample r = got.get();
        dropped[0] += r.dropped();
        r.sample().param("bench:ns").ifPresent(sent -> {
            long nowNs = wallNanos();
            latencies.add((nowNs - Long.parseLong(sent)) / 1e6);
        });
    }

    private static double percentile(List<Double> sorted, double q) {
        if (sorted.isEmpty()) {
            return 0.0;
        }
        return sorted.get((int) (q * (sorted.size() - 1)));
    }

    /* Wall-clock time in ns (microsecond resolution on Linux), comparable across processes. */
    private static long wallNanos() {
        java.time.Instant now = java.time.Instant.now();
        return now.getEpochSecond() * 1_000_000_000L + now.getNano();
    }

    /* The process's CPU time (all threads), as the C++ and Python modes measure it. */
    private static long cpuNanos() {
        return ProcessHandle.current().info().totalCpuDuration().map(Duration::toNanos).orElse(0L);
    }

    /* Content that makes the post's XML about size bytes (its envelope measured by encoding it). */
    private static String padding(int size) {
        Message probe = Message.builder(TYPE).sender(NAME).to(WHITEBOARD).noreply(true)
                .posted(AirTime.of(0, 0)).build();
        int envelope = new String(Codec.encode(probe), StandardCharsets.UTF_8).length();
        return "x".repeat(Math.max(0, size - envelope));
    }
}
