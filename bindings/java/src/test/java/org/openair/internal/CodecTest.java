package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.nio.charset.StandardCharsets;
import java.util.List;
import org.junit.jupiter.api.Nested;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.CsvSource;
import org.junit.jupiter.params.provider.ValueSource;
import org.openair.ApiMisuseException;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.RemoteProtocolException;
import org.openair.Slot;

/** Codec and parser units beyond the shared vectors: hostile input, writing rules. */
class CodecTest {
    static RemoteProtocolException refused(String xml) {
        return assertThrows(RemoteProtocolException.class,
                () -> Codec.decode(xml.getBytes(StandardCharsets.UTF_8)));
    }

    @Nested
    class HostileInput {
        @Test
        void xincludeIsNotProcessed() {
            Message m = Codec.decode(("<message xmlns:xi=\"http://www.w3.org/2001/XInclude\">"
                    + "<type>A</type><xi:include href=\"file:///etc/passwd\"/></message>")
                    .getBytes(StandardCharsets.UTF_8));
            assertEquals("include", m.extras().get(0).name()); // kept as an unknown slot
            assertEquals("", m.extras().get(0).value());
        }

        @ParameterizedTest
        @ValueSource(strings = {
            "<!DOCTYPE message [<!ENTITY x SYSTEM \"file:///etc/passwd\">]><message/>",
            "<?xml version=\"1.0\"?>\n<!doctype message><message><type>A</type></message>",
            "<message><type>&xxe;</type></message>",
            "<message><type>A</type><to>&unknown;</to></message>",
        })
        void entitiesAndDoctypesAreForbidden(String xml) {
            assertEquals(ErrorCode.XML_FORBIDDEN, refused(xml).code()); // OA-SEC-1, OA-SEC-2
        }

        @Test
        void depthIsBoundedWhileParsing() {
            String deep = "<a>".repeat(100_000) + "</a>".repeat(100_000);
            assertEquals(ErrorCode.XML_TOO_DEEP,
                    refused("<message><type>A</type><x>" + deep + "</x></message>").code());
        }

        @Test
        void sizeIsBounded() {
            byte[] big = ("<message><type>A</type><content>" + "x".repeat(2000)
                    + "</content></message>").getBytes(StandardCharsets.UTF_8);
            RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                    () -> Codec.decode(big, List.of(), 1000, 64));
            assertEquals(ErrorCode.XML_MALFORMED, e.code());
        }

        @ParameterizedTest
        @ValueSource(strings = {"", "   ", "<message>", "<message><type>A</type></message><x/>",
            "\u0000", "<message><type>A</type></mesage>", "<?xml version=\"1.0\" "
                + "encoding=\"ISO-8859-1\"?><message><type>A</type></message>"})
        void brokenDocumentsAreMalformed(String xml) {
            assertEquals(ErrorCode.XML_MALFORMED, refused(xml).code()); // OA-MSG-1
        }

        @Test
        void invalidUtf8IsMalformed() {
            byte[] bytes = "<message><type>A\u00e9</type></message>".getBytes(
                    StandardCharsets.ISO_8859_1);
            RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                    () -> Codec.decode(bytes));
            assertEquals(ErrorCode.XML_MALFORMED, e.code());
        }

        @Test
        void errorsCarryTheirWireText() {
            RemoteProtocolException e = refused("<message><priority>1</priority></message>");
            assertEquals(ErrorCode.MESSAGE_INVALID, e.code());
            assertTrue(e.wireText().startsWith("MESSAGE_INVALID: "), e.wireText()); // OA-ERR-2
        }
    }

    @Nested
    class Writing {
        @ParameterizedTest
        @CsvSource({"2.0, 2.0", "2, 2.0", "0.5, 0.5", "6.999, 6.999", "0.00001, 0.00001",
            "30, 30.0", "1e21, 1000000000000000000000.0", "-0.0, 0.0"})
        void decimalsAreShortestWithoutExponent(double value, String text) {
            assertEquals(text, TimeXml.formatDecimal(value, "x"));
        }

        @ParameterizedTest
        @ValueSource(strings = {"a\u0000b", "\uD800", "x\uFFFE"})
        void charactersXmlCannotCarryAreMisuse(String text) {
            Message m = Message.builder("A").content(text).build();
            assertThrows(ApiMisuseException.class, () -> Codec.encode(m)); // OA-MSG-14
        }

        @Test
        void supplementaryCharactersAreWritten() {
            Message m = Message.builder("A").content("\uD83C\uDF89").build();
            assertEquals("\uD83C\uDF89", Codec.decode(Codec.encode(m)).content());
        }

        @Test
        void xmlContentMustBeWellFormed() {
            Message m = Message.builder("A").xmlContent("<a><b></a>").build();
            assertThrows(ApiMisuseException.class, () -> Codec.encode(m));
        }

        @Test
        void textContentCannotClaimXml() {
            Message m = Message.builder("A").content("x").language("XML").build();
            assertThrows(ApiMisuseException.class, () -> Codec.encode(m));
        }

        @Test
        void unknownSlotsCannotShadowKnownOnesOrBeBadNames() {
            Message shadow = Message.builder("A").extra(Slot.text("Content", "x")).build();
            assertThrows(ApiMisuseException.class, () -> Codec.encode(shadow));
            Message bad = Message.builder("A").extra(Slot.text("1bad name", "x")).build();
            assertThrows(ApiMisuseException.class, () -> Codec.encode(bad));
        }

        @Test
        void emptyTypeIsMisuse() {
            assertThrows(ApiMisuseException.class,
                    () -> Codec.encode(Message.builder("").build())); // OA-MSG-2
        }

        @Test
        void binaryChunksAreAnnouncedAndTravelAfterTheXml() {
            Message m = Message.builder("Stream.Sample").binary(List.of(new byte[] {1, 2, 3},
                    new byte[0], new byte[] {9})).build();
            byte[] xml = Codec.encode(m);
            String text = new String(xml, StandardCharsets.UTF_8);
            assertTrue(text.contains("<binarysizes>3,0,1</binarysizes>"
                    + "<totalbinarysize>4</totalbinarysize>"), text); // OA-FRAME-4
            FrameReader r = new FrameReader();
            r.feed(new Frame(Frame.Tag.MESSAGE, xml, m.binary()).encode());
            Frame f = r.next();
            Message back = Codec.decode(f.xml(), f.chunks(), 1 << 20, 64);
            assertEquals(m, back);
            assertArrayEquals(new byte[] {9}, back.binary().get(2));
        }

        @Test
        void attributeOrderIsKeptThroughXmlContent() {
            String xml = "<tcplocation port=\"1\" address=\"h\" name=\"n&amp;&quot;&#10;\"/>";
            Message m = Message.builder("A").xmlContent(xml).build();
            assertEquals(xml, Codec.decode(Codec.encode(m)).content());
        }
    }
}
