package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;

import java.util.List;
import java.util.Map;
import org.junit.jupiter.api.Test;
import org.openair.ApiMisuseException;
import org.openair.DataSample;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.RemoteProtocolException;
import org.openair.Slot;
import org.openair.StreamAlarm;

/** The media commands' contents and the readers of stream replies, hostile replies included. */
class StreamWireTest {
    static Message reply(String type, String content, boolean xml, List<byte[]> chunks) {
        Message.Builder b = Message.builder(type).binary(chunks);
        return (xml ? b.xmlContent(content) : b.content(content)).build();
    }

    static ErrorCode code(Runnable r) {
        return assertThrows(RemoteProtocolException.class, r::run).code();
    }

    @Test
    void requestContents() {
        assertEquals("WAIT_FOR_LAST_AFTERID 500", StreamWire.waitType(true, true, 500));
        assertEquals("WAIT_FOR_FIRST_SAMPLE 0", StreamWire.waitType(false, false, 0));
        assertEquals("<time sec=\"-2\" msec=\"999\"/>", StreamWire.timeContent(-1001));
        assertEquals("<objectcollection><object><datasample/></object><object><datasample/>"
                + "</object></objectcollection>", StreamWire.addSamplesContent(2));
        assertEquals("<samplesearch><param name=\"a&amp;&quot;\">x&lt;</param></samplesearch>",
                StreamWire.searchContent(null, null, Map.of("a&\"", "x<"), 0));
        assertEquals("3-9", StreamWire.lockContent(3, 9));
        assertThrows(ApiMisuseException.class, () -> StreamWire.waitType(true, false, -1));
        assertThrows(ApiMisuseException.class, () -> StreamWire.addSamplesContent(0));
        assertThrows(ApiMisuseException.class, () -> StreamWire.lockContent(-1, 2));
        assertThrows(ApiMisuseException.class,
                () -> StreamWire.searchContent(null, null, Map.of(), -1));
    }

    @Test
    void hostileRepliesAreRefusedByName() {
        byte[] chunk = SampleCodec.encode(DataSample.of(new byte[] {1}));
        assertEquals(ErrorCode.SAMPLE_INVALID, code(() -> StreamWire.sampleOf(
                reply("DATASAMPLE", "<datasample/>", true, List.of()))));
        assertEquals(ErrorCode.SAMPLE_INVALID, code(() -> StreamWire.sampleOf(
                reply("DATASAMPLE", "<datasample/>", true, List.of(new byte[] {9, 0, 0, 0, 0})))));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.samplesOf(reply(
                "DATASAMPLES", "<objectcollection><object><datasample/></object>"
                        + "</objectcollection>", true, List.of(chunk, chunk)))));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.integerOf(
                reply("COUNT", "-3", false, List.of()), "count")));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.integerOf(
                reply("COUNT", "99999999999999999999", false, List.of()), "count")));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.idsOf(
                reply("DATA_ACCEPTED", "<collection><item>1</item></collection>", true,
                        List.of()))));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.timestampOf(
                reply("TIMESTAMP", "<time msec=\"1\"/>", true, List.of()))));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.infoOf(
                reply("INFO", "<streaminfo name=\"S\" count=\"x\"/>", true, List.of()))));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.receivedOf(
                Message.builder("DATASAMPLE").xmlContent("<datasample/>").binary(List.of(chunk))
                        .extra(Slot.text("dropped", "many")).build(), 0)));
        assertEquals(ErrorCode.CONTENT_INVALID, code(() -> StreamWire.alarmOf(
                reply("AIR.Stream.Alarm.Gap", "<dictionary><entry>1</entry></dictionary>", true,
                        List.of()))));
    }

    @Test
    void repliesAreRead() {
        assertEquals(List.of(4L, 5L), StreamWire.idsOf(reply("DATA_ACCEPTED",
                "<collection><entry>4</entry><entry> 5 </entry></collection>", true, List.of())));
        assertEquals(1795328400120L, StreamWire.timestampOf(reply("TIMESTAMP",
                "<time sec=\"1795328400\" msec=\"120\"/>", true, List.of())));
        StreamAlarm a = StreamWire.alarmOf(reply("AIR.Stream.Alarm.HardLimit",
                "<dictionary><entry name=\"stream\">Mic1</entry><entry name=\"dropped\">3</entry>"
                        + "</dictionary>", true, List.of()));
        assertEquals("HardLimit", a.kind());
        assertEquals("Mic1", a.stream());
        assertEquals("3", a.entries().get("dropped"));
        assertEquals(List.of(), StreamWire.streamsOf(reply("STREAMS", "", false, List.of())));
    }
}
