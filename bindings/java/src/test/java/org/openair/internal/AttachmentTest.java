package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.nio.charset.StandardCharsets;
import java.util.List;
import org.junit.jupiter.api.Test;
import org.openair.DeliveryPath;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.RemoteProtocolException;
import org.openair.Wakeup;

/** Attachments (OA-MSG-21, OA-WAKE-10, OA-RET-19): a frame's chunks go to its nested copies. */
class AttachmentTest {
    static final String TRIGGER = "<message><type>T.A</type><id>t</id><binarysizes>4</binarysizes>"
            + "<totalbinarysize>4</totalbinarysize><content language=\"\"/></message>";
    static final String RETRIEVED = "<message><type>T.B</type><id>r</id>"
            + "<binarysizes>3,5</binarysizes><totalbinarysize>8</totalbinarysize>"
            + "<content language=\"\"/></message>";
    static final String PLAIN = "<message><type>T.C</type><id>p</id><content language=\"\"/>"
            + "</message>";

    static Message wakeup(List<byte[]> chunks) {
        return Message.builder(ContentObjects.WAKEUP_TYPE).xmlContent("<objectdictionary>"
                + "<object name=\"TriggerMessage\">" + TRIGGER + "</object>"
                + "<object name=\"RetrievedMessages\"><objectcollection><object>" + PLAIN
                + "</object><object>" + RETRIEVED + "</object></objectcollection></object>"
                + "</objectdictionary>").binary(chunks).build();
    }

    @Test
    void theSpecExampleGivesEachNestedCopyItsChunks() {
        byte[] a = {1, 2, 3, 4};
        byte[] b = {5, 6, 7};
        byte[] c = {8, 9, 10, 11, 12};
        Message w = wakeup(List.of(a, b, c));
        // The outer frame lists the concatenation: 4,3,5 (spec 3.4).
        String xml = new String(Codec.encode(w), StandardCharsets.UTF_8);
        assertTrue(xml.contains("<binarysizes>4,3,5</binarysizes><totalbinarysize>12"), xml);
        Wakeup got = ContentObjects.parseWakeup(w, 0, DeliveryPath.CALLBACK);
        assertEquals(1, got.trigger().binaryCount());
        assertArrayEquals(a, got.trigger().binary().get(0));
        assertEquals(0, got.retrieved().get(0).binaryCount());
        assertArrayEquals(b, got.retrieved().get(1).binary().get(0));
        assertArrayEquals(c, got.retrieved().get(1).binary().get(1));
    }

    @Test
    void chunksThatDoNotMatchAreContentInvalid() {
        for (List<byte[]> chunks : List.of(List.<byte[]>of(), List.of(new byte[4], new byte[3]),
                List.of(new byte[4], new byte[3], new byte[6]),
                List.of(new byte[4], new byte[3], new byte[5], new byte[1]))) {
            RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                    () -> ContentObjects.parseWakeup(wakeup(chunks), 0, DeliveryPath.CALLBACK));
            assertEquals(ErrorCode.CONTENT_INVALID, e.code());
        }
    }

    @Test
    void retrieveResultsTakeTheirChunksInOrder() {
        Message reply = Message.builder("AIR.Retrieve.Success").xmlContent("<objectcollection>"
                + "<object>" + RETRIEVED + "</object><object>" + TRIGGER + "</object>"
                + "</objectcollection>").binary(List.of(new byte[] {1, 1, 1},
                        new byte[] {2, 2, 2, 2, 2}, new byte[] {3, 3, 3, 3})).build();
        List<Message> got = ContentObjects.parseMessageCollection(reply);
        assertEquals(2, got.get(0).binaryCount());
        assertArrayEquals(new byte[] {3, 3, 3, 3}, got.get(1).binary().get(0));
    }

    @Test
    void theDecoderAdoptsTheFramesChunksButTheApiCopies() {
        byte[] chunk = {1, 2, 3};
        Message got = Codec.decode("<message><type>T</type><binarysizes>3</binarysizes>"
                .concat("<content/></message>").getBytes(StandardCharsets.UTF_8), List.of(chunk),
                SafeXml.DEFAULT_MAX_BYTES, SafeXml.DEFAULT_MAX_DEPTH);
        chunk[0] = 7; // the decoder's message views the frame's array (no second copy)
        assertEquals(7, got.binaryView(0).get(0));
        byte[] mine = {1, 2, 3};
        Message built = Message.builder("T").binary(List.of(mine)).build();
        mine[0] = 7; // a caller's message keeps its own copy
        assertEquals(1, built.binaryView(0).get(0));
        got.binary().get(0)[1] = 9; // and binary() hands out copies
        assertEquals(2, got.binaryView(0).get(1));
    }

    @Test
    void aPostCarriesItsAttachmentsAfterTheXml() {
        Message post = Message.builder("T.Att").to("WB1").content("x")
                .binary(List.of(new byte[] {9, 8}, new byte[0])).build();
        byte[] xml = Codec.encode(post);
        byte[] frame = new Frame(Frame.Tag.MESSAGE, xml, post.binary()).encode();
        assertEquals(12 + xml.length + 2, frame.length);
        assertTrue(new String(xml, StandardCharsets.UTF_8)
                .contains("<binarysizes>2,0</binarysizes><totalbinarysize>2</totalbinarysize>"));
        FrameReader r = new FrameReader();
        r.feed(frame, 0, frame.length);
        Frame f = r.next();
        Message back = Codec.decode(f.xml(), f.chunks(), SafeXml.DEFAULT_MAX_BYTES,
                SafeXml.DEFAULT_MAX_DEPTH);
        assertEquals(post.toBuilder().posted(null).build().binaryCount(), back.binaryCount());
        assertArrayEquals(new byte[] {9, 8}, back.binary().get(0));
    }
}
