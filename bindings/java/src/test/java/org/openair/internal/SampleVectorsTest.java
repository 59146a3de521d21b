package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertFalse;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.nio.ByteBuffer;
import java.util.ArrayList;
import java.util.List;
import java.util.Map;
import java.util.stream.Stream;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.Arguments;
import org.junit.jupiter.params.provider.MethodSource;
import org.openair.ApiMisuseException;
import org.openair.DataSample;
import org.openair.ErrorCode;
import org.openair.OpenAirException;
import org.openair.RemoteProtocolException;

/**
 * Every row of spec/vectors/samples/chunks.json (spec 11.2, OA-STREAM-2, OA-STREAM-10): valid
 * chunks decode to their sample and encode back byte for byte, invalid ones are SAMPLE_INVALID,
 * unencodable parameters are API_MISUSE.
 */
class SampleVectorsTest {
    private static final Map<String, Object> FILE = Vectors.json("samples", "chunks.json");

    static Stream<Arguments> rows(String kind) {
        return Vectors.list(FILE, kind).stream().map(r -> Arguments.of(r.get("name"), r));
    }

    static Stream<Arguments> valid() {
        return rows("valid");
    }

    static Stream<Arguments> invalid() {
        return rows("invalid");
    }

    static Stream<Arguments> unencodable() {
        return rows("unencodable");
    }

    @SuppressWarnings("unchecked")
    static List<DataSample.Param> params(Map<String, Object> row) {
        List<DataSample.Param> out = new ArrayList<>();
        for (Object pair : (List<Object>) row.get("params")) {
            List<Object> kv = (List<Object>) pair;
            out.add(new DataSample.Param((String) kv.get(0), (String) kv.get(1)));
        }
        return out;
    }

    @Test
    void theFileHasEveryKindOfRow() {
        assertEquals("openair-sample-vectors/1", FILE.get("format"));
        assertFalse(Vectors.list(FILE, "valid").isEmpty());
        assertFalse(Vectors.list(FILE, "invalid").isEmpty());
        assertFalse(Vectors.list(FILE, "unencodable").isEmpty());
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("valid")
    void aValidChunkDecodesAndEncodesBack(String name, Map<String, Object> row) {
        byte[] chunk = Vectors.unhex((String) row.get("chunk"));
        DataSample s = SampleCodec.decode(chunk);
        assertEquals(row.get("payload"), Vectors.hex(s.payloadBytes()), name);
        assertEquals(params(row), s.params(), name);
        assertTrue(s.payload().isReadOnly());
        DataSample built = new DataSample(ByteBuffer.wrap(Vectors.unhex(
                (String) row.get("payload"))), params(row));
        assertArrayEquals(chunk, SampleCodec.encode(built), name);
        assertEquals(built, s);
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("valid")
    void aDecodedPayloadViewsTheChunk(String name, Map<String, Object> row) {
        byte[] chunk = Vectors.unhex((String) row.get("chunk"));
        DataSample s = SampleCodec.decode(chunk);
        if (s.size() > 0) {
            chunk[4] ^= 0x5A; // the payload is a view of the chunk, not a copy
            assertEquals(chunk[4], s.payload().get(0), name);
        }
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("invalid")
    void anInvalidChunkIsSampleInvalid(String name, Map<String, Object> row) {
        byte[] chunk = Vectors.unhex((String) row.get("chunk"));
        int max = row.containsKey("max_params") ? ((Number) row.get("max_params")).intValue()
                : SampleCodec.MAX_PARAMS;
        RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                () -> SampleCodec.decode(ByteBuffer.wrap(chunk), max), name);
        assertEquals(ErrorCode.valueOf((String) row.get("error")), e.code(), name);
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("unencodable")
    void unencodableParametersAreApiMisuse(String name, Map<String, Object> row) {
        DataSample s = new DataSample(ByteBuffer.allocate(0), params(row));
        OpenAirException e = assertThrows(ApiMisuseException.class, () -> SampleCodec.encode(s));
        assertEquals(ErrorCode.valueOf((String) row.get("error")), e.code(), name);
    }

    @Test
    void partsCarryTheCallersPayloadUncopied() {
        byte[] payload = {1, 2, 3, 4};
        DataSample s = DataSample.of(payload);
        SampleCodec.Parts parts = SampleCodec.parts(s);
        payload[0] = 9; // the parts view the caller's array
        assertEquals(9, parts.join()[4]);
        assertEquals(4 + 4 + 1, parts.size());
    }

    @Test
    void withParamsReplacesInPlaceAndAppends() {
        DataSample s = new DataSample(ByteBuffer.allocate(0), List.of(
                new DataSample.Param("a", "1"), new DataSample.Param("b", "2"),
                new DataSample.Param("a", "3")));
        DataSample t = s.withParams(new java.util.LinkedHashMap<>(Map.of("a", "x")))
                .withParams(Map.of("c", "y"));
        assertEquals(List.of(new DataSample.Param("a", "x"), new DataSample.Param("b", "2"),
                new DataSample.Param("c", "y")), t.params());
        assertEquals(java.util.OptionalLong.empty(), t.id());
    }
}
