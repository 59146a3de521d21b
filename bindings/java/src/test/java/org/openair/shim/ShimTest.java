package org.openair.shim;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.io.BufferedReader;
import java.io.ByteArrayOutputStream;
import java.io.PrintStream;
import java.io.StringReader;
import java.nio.charset.StandardCharsets;
import java.util.List;
import java.util.Map;
import java.util.concurrent.TimeUnit;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.api.Timeout;
import org.openair.AirTime;
import org.openair.Message;
import org.openair.internal.Json;

/** The shim's answers, without a server: ready, errors, message objects. */
class ShimTest {
    static final ByteArrayOutputStream STDERR = new ByteArrayOutputStream();

    @SuppressWarnings("unchecked")
    static List<Map<String, Object>> run(String... lines) throws Exception {
        ByteArrayOutputStream bytes = new ByteArrayOutputStream();
        PrintStream out = new PrintStream(bytes, true, StandardCharsets.UTF_8);
        PrintStream err = System.err;
        System.setErr(new PrintStream(STDERR, true, StandardCharsets.UTF_8));
        int code;
        try {
            code = new ShimMain(out).serve(new BufferedReader(
                    new StringReader(String.join("\n", lines) + "\n")));
        } finally {
            System.setErr(err);
        }
        assertEquals(0, code);
        return bytes.toString(StandardCharsets.UTF_8).lines()
                .map(l -> (Map<String, Object>) Json.parse(l)).toList();
    }

    @Test
    @Timeout(value = 20, unit = TimeUnit.SECONDS)
    void saysReadyAndAnswersEveryCommand() throws Exception {
        List<Map<String, Object>> got = run(
                "{\"seq\": 1, \"cmd\": \"post\", \"to\": \"WB1\", \"type\": \"A\"}",
                "not json",
                "{\"seq\": 2, \"cmd\": \"dance\"}",
                "{\"seq\": 3, \"cmd\": \"connect\", \"host\": \"127.0.0.1\", \"port\": 1,"
                        + " \"name\": \"J\"}",
                "{\"seq\": 4, \"cmd\": \"close\"}",
                "{\"seq\": 5, \"cmd\": \"post\"}");
        assertEquals("ready", got.get(0).get("event"));
        assertEquals("openair-shim/1", got.get(0).get("protocol"));
        assertEquals("API_MISUSE", error(got.get(1))); // connect first
        assertEquals("API_MISUSE", error(got.get(2))); // unknown command
        assertEquals(3L, got.get(3).get("seq"));
        assertEquals("CONNECTION_CLOSED", error(got.get(3))); // nothing listens on port 1
        assertEquals(Map.of("seq", 4L, "ok", true), got.get(4));
        assertEquals(5, got.size()); // nothing is read after close
        assertTrue(STDERR.toString(StandardCharsets.UTF_8).contains("not a JSON command"));
    }

    @SuppressWarnings("unchecked")
    static String error(Map<String, Object> answer) {
        assertEquals(false, answer.get("ok"));
        return (String) ((Map<String, Object>) answer.get("error")).get("code");
    }

    @Test
    void messageObjectsHaveEveryField() {
        Message m = Message.builder("T").id("i").posted(AirTime.of(5, 6)).wbid(3L)
                .priority(1.5).binary(List.of(new byte[] {1, 2, 3, 4}, new byte[0])).build();
        Map<String, Object> o = ShimMain.message(m);
        assertEquals(List.of("type", "id", "from", "to", "cc", "stored", "isresponse", "posted",
                "received", "priority", "wbid", "content", "xml", "attachments"),
                List.copyOf(o.keySet()));
        assertEquals(List.of(5L, 6L), o.get("posted"));
        assertEquals(3L, o.get("wbid"));
        assertEquals(List.of("AQIDBA==", ""), o.get("attachments")); // base64, in order
    }
}
