package org.openair.shim;

import java.nio.charset.StandardCharsets;
import java.util.Locale;
import org.openair.AirTime;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;
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
 * <p>Threading: the posts are sent from the main thread; the library's threads read replies.
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
        if (args.length != 5 || !args[0].equals("post")) {
            System.err.println("usage: BenchMain post HOST PORT N SIZE");
            System.exit(2);
        }
        try {
            post(args[1], Integer.parseInt(args[2]), Integer.parseInt(args[3]),
                    Integer.parseInt(args[4]));
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

    /* Content that makes the post's XML about size bytes (its envelope measured by encoding it). */
    private static String padding(int size) {
        Message probe = Message.builder(TYPE).sender(NAME).to(WHITEBOARD).noreply(true)
                .posted(AirTime.of(0, 0)).build();
        int envelope = new String(Codec.encode(probe), StandardCharsets.UTF_8).length();
        return "x".repeat(Math.max(0, size - envelope));
    }
}
