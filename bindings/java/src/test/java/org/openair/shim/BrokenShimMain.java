package org.openair.shim;

import java.io.BufferedReader;
import java.io.ByteArrayOutputStream;
import java.io.IOException;
import java.io.InputStreamReader;
import java.io.OutputStream;
import java.io.PrintStream;
import java.io.Reader;
import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.TreeSet;
import java.util.function.UnaryOperator;
import org.openair.internal.FrameFaults;
import org.openair.internal.Json;

/**
 * Test only: the Java conformance shim with one behaviour broken on purpose, so that
 * tests/bindings/test_java_binding.py can prove {@code openair conform-client} catches a
 * misbehaving Java binding.
 *
 * <pre>
 *   java -jar target/openair-shim-broken.jar --break NAME   the shim (openair-shim/1), NAME broken
 *   java -jar target/openair-shim-broken.jar --list         every NAME but the stream ones
 *   java -jar target/openair-shim-broken.jar --list-streams the stream breaks' NAMEs
 * </pre>
 *
 * <p>Shim-layer breaks rewrite a command before {@link ShimMain} sees it or an answer before it
 * reaches standard output; the real shim runs unchanged in between. Library breaks install a
 * fault of {@link FrameFaults}, which rewrites what the library puts on the wire through the
 * library's package-private test seam. This class and FrameFaults live in src/test/java and are
 * packaged only into target/openair-shim-broken.jar, never into openair.jar or openair-shim.jar.
 *
 * <p>Threading: as {@link ShimMain}; the rewrites run on the main thread.
 */
public final class BrokenShimMain {
    /** Rewrites one command or one answer; {@code cmd} is the command's name. */
    private interface Rewrite {
        Map<String, Object> apply(String cmd, Map<String, Object> line);
    }

    /** A shim-layer break: how it rewrites commands and answers. */
    private record Break(Rewrite command, Rewrite answer) {}

    private static final Rewrite SAME = (cmd, line) -> line;

    private static final Map<String, Break> SHIM_BREAKS = shimBreaks();

    private BrokenShimMain() {}

    private static Map<String, Break> shimBreaks() {
        Map<String, Break> b = new LinkedHashMap<>();
        // Report the trigger message's from and to swapped.
        b.put("wrong-trigger", onAnswer("await-wakeup", a -> withWakeup(a, w -> {
            Map<String, Object> trigger = obj(w.get("trigger"));
            if (trigger == null) {
                return w;
            }
            Map<String, Object> swapped = with(trigger, "from", trigger.get("to"));
            return with(w, "trigger", with(swapped, "to", trigger.get("from")));
        })));
        // Report retrieved messages oldest first.
        b.put("retrieve-oldest-first", onAnswer("retrieve", a -> {
            List<Object> messages = new ArrayList<>(list(a.get("messages")));
            Collections.reverse(messages);
            return with(a, "messages", messages);
        }));
        // Report a callback delivery as a listener one and the other way round.
        b.put("path-swapped", onAnswer("await-wakeup", a -> withWakeup(a, w -> with(w, "path",
                "callback".equals(w.get("path")) ? "listener" : "callback"))));
        // Report a phase update as if the wakeup message itself had triggered it.
        b.put("phase-as-trigger", onAnswer("await-wakeup", a -> withWakeup(a, w ->
                w.get("trigger") != null ? w : with(w, "trigger", w.get("message")))));
        // Never report a legacy server.
        b.put("legacy-hidden", onAnswer("connect", a -> with(a, "legacy", false)));
        // Post XML content as text.
        b.put("xml-as-text", new Break((cmd, c) -> cmd.startsWith("post") ? with(c, "xml", false)
                : c, SAME));
        // Report every failure as REQUEST_FAILED, whatever the library's error was.
        b.put("errors-as-request-failed", new Break(SAME, (cmd, a) ->
                Boolean.FALSE.equals(a.get("ok"))
                        ? with(a, "error", with(obj(a.get("error")), "code", "REQUEST_FAILED"))
                        : a));
        // Never open the callback connection (connect still succeeds).
        b.put("no-callback", new Break((cmd, c) -> cmd.equals("connect")
                ? with(c, "callback", false) : c, SAME));
        // With the library fault of the same name: mark the next post-noreply for noreply="yes".
        b.put("noreply-to-legacy", new Break((cmd, c) -> {
            if (cmd.equals("post-noreply")) {
                FrameFaults.markNoReply(String.valueOf(c.get("type")));
            }
            return c;
        }, SAME));
        // Streams: report a wait whose timeout passed as SAMPLE_UNKNOWN instead of "none".
        b.put("wait-timeout-error", new Break(SAME, (cmd, a) -> cmd.equals("stream-wait")
                && Boolean.TRUE.equals(a.get("ok")) && a.get("sample") == null
                ? failure(a, "SAMPLE_UNKNOWN", "no sample before the timeout") : a));
        // Streams: report the end of a push connection as a timeout.
        b.put("push-end-silent", new Break(SAME, (cmd, a) -> cmd.equals("stream-next")
                && Boolean.FALSE.equals(a.get("ok"))
                && "CONNECTION_CLOSED".equals(obj(a.get("error")).get("code"))
                ? failure(a, "REQUEST_TIMEOUT", "no sample within the timeout") : a));
        // Streams: write builtin:timestamp and builtin:seq before the writer's parameters.
        b.put("builtins-first", new Break((cmd, c) -> cmd.equals("stream-add")
                ? builtinsFirst(c) : c, SAME));
        // Attachments: the post goes out without the attachments it was given.
        b.put("attachments-dropped", new Break((cmd, c) -> cmd.startsWith("post")
                && c.containsKey("attachments") ? without(c, "attachments") : c, SAME));
        // Streams: acknowledge the registration's samples (the library does) but never report them.
        b.put("registration-samples-lost", new Break(SAME, (cmd, a) -> cmd.equals("await-sample")
                && Boolean.TRUE.equals(a.get("ok"))
                ? failure(a, "REQUEST_TIMEOUT", "no sample within the timeout") : a));
        return b;
    }

    /** The stream breaks (listed by {@code --list-streams}, not by {@code --list}). */
    static final List<String> STREAM_BREAKS = List.of("push-no-ack", "wait-timeout-error",
            "push-end-silent", "builtins-first", "registration-samples-lost",
            "add-sample-no-binarysizes", "attachments-dropped");

    /** A failure answer in place of {@code answer}. */
    private static Map<String, Object> failure(Map<String, Object> answer, String code,
            String message) {
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("seq", answer.get("seq"));
        out.put("ok", false);
        out.put("error", Map.of("code", code, "message", message));
        return out;
    }

    /** stream-add with timestamp_ms and sample_seq turned into parameters before the writer's. */
    private static Map<String, Object> builtinsFirst(Map<String, Object> c) {
        List<Object> params = new ArrayList<>();
        if (c.get("timestamp_ms") != null) {
            params.add(List.of("builtin:timestamp", String.valueOf(c.get("timestamp_ms"))));
        }
        if (c.get("sample_seq") != null) {
            params.add(List.of("builtin:seq", String.valueOf(c.get("sample_seq"))));
        }
        if (c.get("params") != null) {
            params.addAll(list(c.get("params")));
        }
        Map<String, Object> out = new LinkedHashMap<>(c);
        out.remove("timestamp_ms");
        out.remove("sample_seq");
        out.put("params", params);
        return out;
    }

    /** A break that rewrites the successful answers to {@code command} only. */
    private static Break onAnswer(String command, UnaryOperator<Map<String, Object>> rewrite) {
        return new Break(SAME, (cmd, a) -> cmd.equals(command) && Boolean.TRUE.equals(a.get("ok"))
                ? rewrite.apply(a) : a);
    }

    private static Map<String, Object> withWakeup(Map<String, Object> answer,
            UnaryOperator<Map<String, Object>> rewrite) {
        return with(answer, "wakeup", rewrite.apply(obj(answer.get("wakeup"))));
    }

    /** A copy of {@code m} without its member {@code key}. */
    private static Map<String, Object> without(Map<String, Object> m, String key) {
        Map<String, Object> copy = new LinkedHashMap<>(m);
        copy.remove(key);
        return copy;
    }

    /** A copy of {@code m} whose member {@code key} is {@code value}, in place or appended. */
    private static Map<String, Object> with(Map<String, Object> m, String key, Object value) {
        Map<String, Object> copy = new LinkedHashMap<>(m);
        copy.put(key, value);
        return copy;
    }

    @SuppressWarnings("unchecked")
    private static Map<String, Object> obj(Object o) {
        return (Map<String, Object>) o;
    }

    @SuppressWarnings("unchecked")
    private static List<Object> list(Object o) {
        return (List<Object>) o;
    }

    /** @return every name {@code --break} accepts, sorted */
    static List<String> names() {
        TreeSet<String> all = new TreeSet<>(SHIM_BREAKS.keySet());
        all.addAll(FrameFaults.names());
        return List.copyOf(all);
    }

    private static int usage() {
        System.err.println("usage: openair-shim-broken --break NAME | --list | --list-streams"
                + "\nNAME is one of: "
                + String.join(" ", names()));
        return 2;
    }

    /**
     * Run the broken shim on standard input and output.
     *
     * @param args {@code --break NAME} or {@code --list}
     * @throws IOException when standard input fails
     */
    public static void main(String[] args) throws IOException {
        PrintStream stdout = new PrintStream(System.out, false, StandardCharsets.UTF_8);
        if (args.length == 1 && (args[0].equals("--list") || args[0].equals("--list-streams"))) {
            boolean streams = args[0].equals("--list-streams");
            names().stream().filter(n -> STREAM_BREAKS.contains(n) == streams)
                    .forEach(stdout::println);
            stdout.flush();
            System.exit(0);
        }
        if (args.length != 2 || !args[0].equals("--break") || !names().contains(args[1])) {
            System.exit(usage());
        }
        String name = args[1];
        Break shimBreak = SHIM_BREAKS.getOrDefault(name, new Break(SAME, SAME));
        FrameFaults.install(name); // false for a shim-layer-only break
        System.setOut(System.err); // nothing but answers may reach standard output
        Commands in = new Commands(new InputStreamReader(System.in, StandardCharsets.UTF_8),
                shimBreak.command());
        Answers answers = new Answers(stdout, in, shimBreak.answer(),
                "openair-java-broken-" + name);
        int code = new ShimMain(new PrintStream(answers, false, StandardCharsets.UTF_8)).serve(in);
        System.exit(code);
    }

    /** The commands, each rewritten before the real shim reads it; remembers the last one. */
    private static final class Commands extends BufferedReader {
        private final Rewrite rewrite;
        private String last = "";

        Commands(Reader in, Rewrite rewrite) {
            super(in);
            this.rewrite = rewrite;
        }

        @Override
        public String readLine() throws IOException {
            String line = super.readLine();
            if (line == null || line.isBlank()) {
                return line;
            }
            Object command;
            try {
                command = Json.parse(line);
            } catch (IllegalArgumentException e) {
                return line; // the real shim reports it
            }
            if (!(command instanceof Map<?, ?>)) {
                return line;
            }
            Map<String, Object> cmd = obj(command);
            last = String.valueOf(cmd.get("cmd"));
            return Json.write(rewrite.apply(last, cmd));
        }
    }

    /** Standard output: each line the real shim writes, rewritten as a whole. */
    private static final class Answers extends OutputStream {
        private final PrintStream out;
        private final Commands commands;
        private final Rewrite rewrite;
        private final String library;
        private final ByteArrayOutputStream line = new ByteArrayOutputStream();

        Answers(PrintStream out, Commands commands, Rewrite rewrite, String library) {
            this.out = out;
            this.commands = commands;
            this.rewrite = rewrite;
            this.library = library;
        }

        @Override
        public void write(int b) {
            if (b != '\n') {
                line.write(b);
                return;
            }
            Map<String, Object> answer = obj(Json.parse(line.toString(StandardCharsets.UTF_8)));
            line.reset();
            if ("ready".equals(answer.get("event"))) {
                answer = with(answer, "library", library); // the report names the broken shim
            } else {
                answer = rewrite.apply(commands.last, answer);
            }
            out.print(Json.write(answer));
            out.print('\n');
        }

        @Override
        public void flush() {
            out.flush();
        }
    }
}
