package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertNotNull;
import static org.junit.jupiter.api.Assertions.assertThrows;

import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.stream.Stream;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.Arguments;
import org.junit.jupiter.params.provider.MethodSource;
import org.openair.AirTime;
import org.openair.Message;
import org.openair.Reference;
import org.openair.RemoteProtocolException;
import org.openair.Slot;
import org.w3c.dom.Element;
import org.w3c.dom.Node;

/**
 * Every case of spec/vectors/messages: decoding gives the expected fields (or exactly the expected
 * error), encoding the decoded message gives the canonical file byte for byte, and the canonical
 * file decodes to the same message and re-encodes to itself.
 */
class MessageVectorsTest {
    private static final Map<String, Object> MANIFEST = Vectors.json("messages", "manifest.json");

    static Stream<Arguments> valid() {
        return Vectors.list(MANIFEST, "cases").stream()
                .filter(c -> Vectors.map(c.get("expected")).containsKey("fields"))
                .map(c -> Arguments.of(c.get("name"), c));
    }

    static Stream<Arguments> invalid() {
        return Vectors.list(MANIFEST, "cases").stream()
                .filter(c -> Vectors.map(c.get("expected")).containsKey("error"))
                .map(c -> Arguments.of(c.get("name"), c));
    }

    static List<byte[]> chunks(Map<String, Object> c) {
        List<byte[]> out = new ArrayList<>();
        @SuppressWarnings("unchecked")
        List<String> hex = (List<String>) c.getOrDefault("chunks", List.of());
        for (String h : hex) {
            out.add(Vectors.unhex(h));
        }
        return out;
    }

    static Message decode(Map<String, Object> c) {
        return Codec.decode(Vectors.bytes("messages", (String) c.get("file")), chunks(c),
                SafeXml.DEFAULT_MAX_BYTES, SafeXml.DEFAULT_MAX_DEPTH);
    }

    static Object time(AirTime t) {
        if (t == null) {
            return null;
        }
        List<Object> out = new ArrayList<>(List.of(t.sec(), (long) t.msec()));
        if (t.usec() != null) {
            out.add((long) t.usec());
        }
        return out;
    }

    static Object reference(Reference r) {
        if (r == null) {
            return null;
        }
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("id", r.id());
        out.put("type", r.type());
        out.put("from", r.sender());
        out.put("to", r.to());
        out.put("cc", r.cc());
        out.put("stored", r.stored());
        out.put("time", time(r.time()));
        return out;
    }

    /** Return the field {@code key} of {@code m} in the manifest's own representation. */
    static Object actual(Message m, String key) {
        return switch (key) {
            case "type" -> m.type();
            case "id" -> m.id();
            case "sender" -> m.sender();
            case "to" -> m.to();
            case "cc" -> m.cc();
            case "stored" -> m.stored();
            case "isresponse" -> m.isresponse();
            case "comment" -> m.comment();
            case "netprotocol" -> m.netprotocol();
            case "posted" -> time(m.posted());
            case "received" -> time(m.received());
            case "inreplyto" -> reference(m.inreplyto());
            case "priority" -> m.priority();
            case "timetolive" -> m.timetolive();
            case "noreply" -> m.noreply();
            case "language" -> m.language();
            case "content_is_xml" -> m.contentIsXml();
            case "content" -> m.content();
            case "history" -> m.history();
            case "wbid" -> m.wbid();
            case "extras" -> {
                List<Object> out = new ArrayList<>();
                for (Slot s : m.extras()) {
                    out.add(List.of(s.name(), s.value(), s.xml()));
                }
                yield out;
            }
            case "binary" -> m.binary().stream().map(Vectors::hex).toList();
            default -> throw new IllegalArgumentException("unknown manifest field " + key);
        };
    }

    static void checkFields(Message m, Map<String, Object> fields) {
        for (Map.Entry<String, Object> e : fields.entrySet()) {
            Object want = e.getValue();
            Object got = actual(m, e.getKey());
            if (want instanceof Number n && got instanceof Number g) {
                assertEquals(n.doubleValue(), g.doubleValue(), 0.0, e.getKey());
            } else {
                assertEquals(want, got, e.getKey());
            }
        }
    }

    static Element firstMessage(Element el) {
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n instanceof Element child) {
                if (Dom.name(child).equals("message")) {
                    return child;
                }
                Element deeper = firstMessage(child);
                if (deeper != null) {
                    return deeper;
                }
            }
        }
        return null;
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("valid")
    void decodesToTheExpectedFields(String name, Map<String, Object> c) {
        Message m = decode(c);
        Map<String, Object> exp = Vectors.map(c.get("expected"));
        checkFields(m, Vectors.map(exp.get("fields")));
        if (exp.containsKey("nested")) {
            Element wrapper = SafeXml.parseWrapped(m.content(), SafeXml.DEFAULT_MAX_DEPTH);
            Element nested = firstMessage(wrapper);
            assertNotNull(nested, "no nested message");
            checkFields(Codec.fromElement(nested), Vectors.map(exp.get("nested")));
        }
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("valid")
    void encodesToTheCanonicalBytes(String name, Map<String, Object> c) {
        byte[] canonical = Vectors.bytes("messages", (String) c.get("canonical"));
        Message m = decode(c);
        assertEquals(new String(canonical, StandardCharsets.UTF_8),
                new String(Codec.encode(m), StandardCharsets.UTF_8));
        assertArrayEquals(canonical, Codec.encode(m));
        Message again = Codec.decode(canonical, chunks(c), SafeXml.DEFAULT_MAX_BYTES,
                SafeXml.DEFAULT_MAX_DEPTH);
        assertEquals(m, again);
        assertArrayEquals(canonical, Codec.encode(again));
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("invalid")
    void refusesWithTheExpectedError(String name, Map<String, Object> c) {
        RemoteProtocolException e = assertThrows(RemoteProtocolException.class, () -> decode(c));
        assertEquals(Vectors.map(c.get("expected")).get("error"), e.code().name(), e.getMessage());
    }
}
