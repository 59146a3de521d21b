package org.openair.shim;

import java.io.BufferedReader;
import java.io.IOException;
import java.io.InputStreamReader;
import java.io.PrintStream;
import java.nio.charset.StandardCharsets;
import java.time.Duration;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Optional;
import java.util.Set;
import java.util.TreeSet;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.OpenAirException;
import org.openair.Options;
import org.openair.Registration;
import org.openair.RequestFailedException;
import org.openair.RequestTimeoutException;
import org.openair.RetrieveSpec;
import org.openair.Trigger;
import org.openair.Wakeup;
import org.openair.internal.Json;

/**
 * The Java binding's conformance shim: {@code openair conform-client} drives the library through
 * it ({@code java -jar target/openair-shim.jar}). It speaks {@code openair-shim/1}
 * (conformance/openair_conformance/shim/PROTOCOL.md): one JSON command per line on standard input,
 * one JSON answer per line on standard output, flushed after each line; logging goes to standard
 * error. The shim only translates: every protocol decision is the library's.
 *
 * <p>Threading: commands run one at a time on the main thread; the library's own threads receive
 * and acknowledge deliveries between commands.
 */
public final class ShimMain {
    /** The protocol spoken. */
    public static final String PROTOCOL = "openair-shim/1";
    /** The library's name in the ready event. */
    public static final String LIBRARY = "openair-java";

    private final PrintStream out;
    private final ShimStreams streams = new ShimStreams(this::module);
    private Module module;
    private boolean closed;

    ShimMain(PrintStream out) {
        this.out = out;
    }

    /**
     * Run the shim on standard input and output.
     *
     * @param args ignored
     * @throws IOException when standard input fails
     */
    public static void main(String[] args) throws IOException {
        PrintStream stdout = new PrintStream(System.out, false, StandardCharsets.UTF_8);
        System.setOut(System.err); // nothing but answers may reach standard output
        BufferedReader in = new BufferedReader(
                new InputStreamReader(System.in, StandardCharsets.UTF_8));
        int code = new ShimMain(stdout).serve(in);
        System.exit(code);
    }

    /**
     * Say ready, then answer commands until {@code close} or end of input.
     *
     * @param in the commands
     * @return the exit code
     * @throws IOException when reading fails
     */
    int serve(BufferedReader in) throws IOException {
        Map<String, Object> ready = new LinkedHashMap<>();
        ready.put("event", "ready");
        ready.put("protocol", PROTOCOL);
        ready.put("library", LIBRARY);
        ready.put("version", OpenAir.VERSION);
        write(ready);
        try {
            String line;
            while (!closed && (line = in.readLine()) != null) {
                if (line.isBlank()) {
                    continue;
                }
                Object command;
                try {
                    command = Json.parse(line);
                } catch (IllegalArgumentException e) {
                    System.err.println("shim: not a JSON command: " + e.getMessage());
                    continue;
                }
                if (!(command instanceof Map<?, ?> map)) {
                    System.err.println("shim: a command must be a JSON object");
                    continue;
                }
                if (!(map.get("seq") instanceof Long seq) || seq < 0) {
                    // OA-GEN-5: it cannot be paired with a command, so nothing goes to stdout
                    System.err.println("shim: a command needs a non-negative integer seq: " + line);
                    continue;
                }
                @SuppressWarnings("unchecked")
                Map<String, Object> cmd = (Map<String, Object>) map;
                write(handle(cmd));
            }
        } finally {
            if (module != null) {
                module.close(); // end of input means close (PROTOCOL.md)
            }
        }
        return 0;
    }

    private void write(Map<String, Object> line) {
        out.print(Json.write(line));
        out.print('\n');
        out.flush();
    }

    private Map<String, Object> handle(Map<String, Object> cmd) {
        Object seq = cmd.getOrDefault("seq", 0L);
        Map<String, Object> answer = new LinkedHashMap<>();
        answer.put("seq", seq);
        try {
            Map<String, Object> fields = run(String.valueOf(cmd.get("cmd")), cmd);
            answer.put("ok", true);
            answer.putAll(fields);
        } catch (RequestFailedException e) {
            answer.put("ok", false);
            // a stream's failure reply names its condition (SAMPLE_UNKNOWN, LOCK_UNKNOWN, …)
            boolean media = String.valueOf(cmd.get("cmd")).startsWith("stream-");
            String code = media ? e.condition().map(Enum::name).orElse(e.code().name())
                    : e.code().name();
            answer.put("error", error(code, e.getMessage()));
        } catch (OpenAirException e) {
            answer.put("ok", false);
            answer.put("error", error(e.code().name(), e.getMessage()));
        } catch (RuntimeException e) { // a command the shim could not turn into a call
            answer.put("ok", false);
            answer.put("error", error("API_MISUSE", String.valueOf(e)));
        }
        return answer;
    }

    private static Map<String, Object> error(String code, String message) {
        Map<String, Object> e = new LinkedHashMap<>();
        e.put("code", code);
        e.put("message", message == null ? code : message);
        return e;
    }

    private Map<String, Object> run(String name, Map<String, Object> cmd) {
        switch (name) {
            case "connect":
                return connect(cmd);
            case "register":
                return register(cmd);
            case "post":
                return post(cmd, false);
            case "post-noreply":
                return post(cmd, true);
            case "retrieve":
                return retrieve(cmd);
            case "await-wakeup":
                return awaitWakeup(cmd);
            case "close":
                closed = true;
                streams.close();
                if (module != null) {
                    module.close();
                }
                return Map.of();
            default:
                Map<String, Object> answer = streams.run(name, cmd);
                if (answer == null) {
                    throw new ApiMisuseException("unknown command '" + name + "'");
                }
                return answer;
        }
    }

    private Module module() {
        if (module == null) {
            throw new ApiMisuseException("connect first");
        }
        return module;
    }

    private static String str(Map<String, Object> m, String key, String dflt) {
        Object v = m.get(key);
        return v == null ? dflt : v.toString();
    }

    private static boolean bool(Map<String, Object> m, String key, boolean dflt) {
        Object v = m.get(key);
        return v == null ? dflt : (Boolean) v;
    }

    private static long num(Map<String, Object> m, String key, long dflt) {
        Object v = m.get(key);
        return v == null ? dflt : ((Number) v).longValue();
    }

    @SuppressWarnings("unchecked")
    private static List<Object> list(Map<String, Object> m, String key) {
        Object v = m.get(key);
        return v == null ? List.of() : (List<Object>) v;
    }

    @SuppressWarnings("unchecked")
    private static Map<String, Object> obj(Object o) {
        return (Map<String, Object>) o;
    }

    private Map<String, Object> connect(Map<String, Object> cmd) {
        if (module != null) {
            throw new ApiMisuseException("already connected");
        }
        Set<String> wanted = new TreeSet<>(Options.SUPPORTED_EXTENSIONS);
        if (cmd.get("extensions") != null) {
            Set<String> offered = new TreeSet<>();
            for (Object e : list(cmd, "extensions")) {
                offered.add(e.toString());
            }
            wanted.retainAll(offered); // the library declares only what it implements
        }
        Options options = Options.builder(str(cmd, "name", ""))
                .server(str(cmd, "host", "127.0.0.1"), (int) num(cmd, "port", 10000))
                .bind(bool(cmd, "bind", true))
                .listen(bool(cmd, "listen", true))
                .callback(bool(cmd, "callback", true))
                .extensions(wanted)
                .build();
        module = OpenAir.connect(options);
        Map<String, Object> out = new LinkedHashMap<>();
        int port = module.boundPort();
        out.put("bound_port", (long) (port > 0 ? port : -1));
        out.put("legacy", module.legacy());
        return out;
    }

    private Map<String, Object> register(Map<String, Object> cmd) {
        List<Trigger> triggers = new ArrayList<>();
        for (Object t : list(cmd, "triggers")) {
            Map<String, Object> m = obj(t);
            triggers.add(new Trigger(str(m, "type", ""), str(m, "from", ""), num(m, "after", 0)));
        }
        List<RetrieveSpec> retrieves = new ArrayList<>();
        for (Object r : list(cmd, "retrieves")) {
            retrieves.add(spec(obj(r)));
        }
        List<String> inputs = new ArrayList<>();
        for (Object source : list(cmd, "streams")) { // OA-STREAM-14
            inputs.add(source.toString());
        }
        module().subscribe(new Registration(triggers, retrieves,
                bool(cmd, "allowselftriggering", false), inputs));
        return Map.of();
    }

    private static RetrieveSpec spec(Map<String, Object> m) {
        Object lastmsec = m.get("lastmsec");
        return new RetrieveSpec(str(m, "whiteboard", ""), str(m, "type", ""), "",
                str(m, "sender", ""), str(m, "content", ""), (int) num(m, "latest", 1),
                lastmsec == null ? null : ((Number) lastmsec).longValue(), null, null);
    }

    private Map<String, Object> post(Map<String, Object> cmd, boolean noreply) {
        Module m = module();
        List<String> cc = new ArrayList<>();
        for (Object name : list(cmd, "cc")) {
            cc.add(name.toString());
        }
        Message.Builder b = Message.builder(str(cmd, "type", "")).sender(m.name())
                .to(str(cmd, "to", "")).cc(cc);
        Object priority = cmd.get("priority");
        if (priority != null) {
            b.priority(((Number) priority).doubleValue());
        }
        String content = str(cmd, "content", "");
        if (bool(cmd, "xml", false)) {
            b.xmlContent(content);
        } else {
            b.content(content);
        }
        List<byte[]> attachments = new ArrayList<>();
        for (Object a : list(cmd, "attachments")) {
            attachments.add(ShimStreams.base64(a));
        }
        b.binary(attachments); // OA-FRAME-4: the post's attachments
        Message sent = noreply ? m.postNoReply(b.build()) : m.post(b.build());
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("id", sent.id());
        return out;
    }

    private Map<String, Object> retrieve(Map<String, Object> cmd) {
        List<RetrieveSpec> specs = new ArrayList<>();
        for (Object s : list(cmd, "specs")) {
            specs.add(spec(obj(s)));
        }
        if (specs.isEmpty()) {
            throw new ApiMisuseException("retrieve needs at least one spec");
        }
        List<Object> found = new ArrayList<>();
        for (Message msg : module().retrieve(specs, str(cmd, "to", "AIRCentral"))) {
            found.add(message(msg));
        }
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("messages", found);
        return out;
    }

    private Map<String, Object> awaitWakeup(Map<String, Object> cmd) {
        long ms = num(cmd, "timeout_ms", 5000);
        Optional<Wakeup> w = module().nextWakeup(Duration.ofMillis(ms));
        if (w.isEmpty()) {
            throw new RequestTimeoutException("no wakeup within " + ms + " ms");
        }
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("wakeup", wakeup(w.get()));
        return out;
    }

    private static Object time(AirTime t) {
        return t == null ? null : List.of(t.sec(), (long) t.msec());
    }

    /** Return a message as the protocol's message object. */
    static Map<String, Object> message(Message m) {
        Map<String, Object> o = new LinkedHashMap<>();
        o.put("type", m.type());
        o.put("id", m.id());
        o.put("from", m.sender());
        o.put("to", m.to());
        o.put("cc", m.cc());
        o.put("stored", m.stored());
        o.put("isresponse", m.isresponse());
        o.put("posted", time(m.posted()));
        o.put("received", time(m.received()));
        o.put("priority", m.priority());
        o.put("wbid", m.wbid());
        o.put("content", m.content());
        o.put("xml", m.contentIsXml());
        List<Object> attachments = new ArrayList<>();
        for (byte[] chunk : m.binary()) {
            attachments.add(java.util.Base64.getEncoder().encodeToString(chunk));
        }
        o.put("attachments", attachments);
        return o;
    }

    /** Return a wakeup as the protocol's wakeup object. */
    static Map<String, Object> wakeup(Wakeup w) {
        Map<String, Object> o = new LinkedHashMap<>();
        o.put("message", message(w.message()));
        o.put("trigger", w.trigger() == null ? null : message(w.trigger()));
        List<Object> retrieved = new ArrayList<>();
        for (Message m : w.retrieved()) {
            retrieved.add(message(m));
        }
        o.put("retrieved", retrieved);
        o.put("lasttrigger", w.lasttrigger());
        o.put("received_ns", w.receivedNanos());
        o.put("path", w.path().name().toLowerCase(java.util.Locale.ROOT));
        return o;
    }
}
