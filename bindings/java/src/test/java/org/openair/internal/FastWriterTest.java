package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertNotEquals;
import static org.junit.jupiter.api.Assertions.assertNotNull;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.nio.charset.StandardCharsets;
import java.util.HashSet;
import java.util.List;
import java.util.Map;
import java.util.Set;
import java.util.UUID;
import java.util.regex.Pattern;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.MethodSource;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.Message;
import org.openair.Slot;

/**
 * The fast writer writes exactly what the DOM path writes, on every message vector and on the
 * messages a client sends; message ids stay fresh UUID-4 strings (OA-MSG-8).
 */
class FastWriterTest {
    private static final Pattern UUID4 = Pattern.compile(
            "[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}");

    static String both(Message m) {
        long[] sizes = Codec.chunkSizes(m);
        String dom = new String(Codec.encodeDom(m, sizes), StandardCharsets.UTF_8);
        String fast = new String(Codec.encode(m), StandardCharsets.UTF_8);
        assertEquals(dom, fast);
        return fast;
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("org.openair.internal.MessageVectorsTest#valid")
    void everyVectorIsWrittenAsTheDomWritesIt(String name, Map<String, Object> c) {
        both(MessageVectorsTest.decode(c));
    }

    @Test
    void clientMessagesTakeTheFastPathWithTheSameBytes() {
        List<Message> sent = List.of(
                Message.builder("Bench.Flow.Data").sender("B").to("WB1").noreply(true)
                        .posted(AirTime.of(1, 2)).content("x & <y> \r \"z\"").build(),
                Message.builder("ADD_SAMPLE").sender("W").to("Cam").posted(new AirTime(5, 6, 7))
                        .xmlContent("<datasample/>").binary(List.of(new byte[3])).build(),
                Message.builder("AIR.Subscribe").sender("M").to("AIRCentral").priority(1.25)
                        .xmlContent("<module name=\"M\" b='2' a=\"1\"><!-- c --><?pi x?>"
                                + "<x>t&amp;</x></module>").comment("c").wbid(7L)
                        .netprotocol("tcp").timetolive(500.0)
                        .extra(Slot.text("extensions", "noreply usec"))
                        .extra(Slot.text("dropped", "")).build(),
                Message.builder("T").language("text/plain").content("é\u00e9").build());
        for (Message m : sent) {
            assertNotNull(FastWriter.write(m, Codec.chunkSizes(m)), m.type());
            both(m);
        }
        Message odd = Message.builder("T").extra(new Slot("x", "<a/>", true)).build();
        assertEquals(null, FastWriter.write(odd, new long[0])); // the DOM path takes it
        both(odd);
    }

    @Test
    void badInputIsRefusedAsTheDomPathRefusesIt() {
        for (Message m : List.of(Message.builder("T").content("a\u0001").build(),
                Message.builder("T").xmlContent("<a>").build(),
                Message.builder("T").extra(Slot.text("WBID", "1")).build())) {
            assertThrows(ApiMisuseException.class, () -> Codec.encode(m));
            assertThrows(ApiMisuseException.class, () -> Codec.encodeDom(m, new long[0]));
        }
    }

    @Test
    void idsAreFreshUuid4Strings() {
        Set<String> seen = new HashSet<>();
        for (int i = 0; i < 10_000; i++) {
            String id = Message.newId();
            assertTrue(UUID4.matcher(id).matches(), id);
            assertEquals(id, UUID.fromString(id).toString());
            assertEquals(4, UUID.fromString(id).version());
            assertEquals(2, UUID.fromString(id).variant());
            assertTrue(seen.add(id), id);
        }
        assertNotEquals(Message.newId(), Message.newId());
    }
}
