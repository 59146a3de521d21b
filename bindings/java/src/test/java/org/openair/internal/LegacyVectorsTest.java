package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertNotNull;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.util.List;
import java.util.Map;
import java.util.stream.Stream;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.Arguments;
import org.junit.jupiter.params.provider.MethodSource;
import org.openair.Message;
import org.openair.RemoteProtocolException;
import org.w3c.dom.Element;

/**
 * Every case of spec/vectors/legacy: what Psyclone 1.1.7 writes, read as a client reads a
 * delivery or a reply (a priority outside 0.0-6.999 clamped, OA-MSG-19), its first nested stored
 * copy read the same way, and the strict reading of a server (OA-MSG-6) refusing what the
 * manifest says it refuses.
 */
class LegacyVectorsTest {
    private static final Map<String, Object> MANIFEST = Vectors.json("legacy", "manifest.json");

    static Stream<Arguments> cases() {
        return Vectors.list(MANIFEST, "cases").stream().map(c -> Arguments.of(c.get("name"), c));
    }

    static byte[] source(Map<String, Object> c) {
        return Vectors.bytes("legacy", (String) c.get("file"));
    }

    static Message decode(Map<String, Object> c, boolean clamp) {
        return Codec.decode(source(c), List.of(), SafeXml.DEFAULT_MAX_BYTES,
                SafeXml.DEFAULT_MAX_DEPTH, clamp);
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("cases")
    void aClientReadsTheExpectedFields(String name, Map<String, Object> c) {
        Message m = decode(c, true);
        Map<String, Object> exp = Vectors.map(c.get("expected"));
        MessageVectorsTest.checkFields(m, Vectors.map(exp.get("fields")));
        if (exp.containsKey("nested")) {
            Element wrapper = SafeXml.parseWrapped(m.content(), SafeXml.DEFAULT_MAX_DEPTH);
            Element nested = MessageVectorsTest.firstMessage(wrapper);
            assertNotNull(nested, "no nested message");
            MessageVectorsTest.checkFields(Codec.fromElement(nested),
                    Vectors.map(exp.get("nested")));
        }
        // A writer stays strict: what was read is written back in range and reads back the same.
        assertEquals(m, Codec.decode(Codec.encode(m)));
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("cases")
    void aServerReadingAPostIsStrict(String name, Map<String, Object> c) {
        if (!c.containsKey("strict")) {
            assertEquals(decode(c, true), decode(c, false));
            return;
        }
        RemoteProtocolException e =
                assertThrows(RemoteProtocolException.class, () -> decode(c, false));
        assertEquals(Vectors.map(c.get("strict")).get("error"), e.code().name(), e.getMessage());
        assertTrue(e.getMessage().contains("priority"), e.getMessage());
    }
}
