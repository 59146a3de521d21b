package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertSame;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.security.MessageDigest;
import java.security.NoSuchAlgorithmException;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.Random;
import java.util.stream.Stream;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.Arguments;
import org.junit.jupiter.params.provider.MethodSource;
import org.openair.RemoteProtocolException;

/**
 * Every case of spec/vectors/frames, fed whole, one byte at a time, in random splits, and whole
 * with feedEof before the frames are taken: every way gives the manifest's frames and ending.
 */
class FrameVectorsTest {
    private static final Map<String, Object> MANIFEST = Vectors.json("frames", "manifest.json");

    static Stream<Arguments> cases() {
        return Vectors.list(MANIFEST, "cases").stream().map(c -> Arguments.of(c.get("name"), c));
    }

    /** What a reader produced from one vector. */
    record Outcome(List<Map<String, Object>> frames, String end, long fed) {}

    static FrameReader reader(Map<String, Object> c) {
        Map<String, Object> lim = Vectors.map(
                c.containsKey("limits") ? c.get("limits") : MANIFEST.get("default_limits"));
        return new FrameReader(((Number) lim.get("max_xml")).longValue(),
                ((Number) lim.get("max_binary")).longValue(), SafeXml.DEFAULT_MAX_DEPTH);
    }

    static String sha256(byte[] data) {
        try {
            return Vectors.hex(MessageDigest.getInstance("SHA-256").digest(data));
        } catch (NoSuchAlgorithmException e) {
            throw new IllegalStateException(e);
        }
    }

    static Map<String, Object> describe(Frame f) {
        Map<String, Object> out = new LinkedHashMap<>();
        out.put("tag", f.tag().wire());
        out.put("xml_len", (long) f.xml().length);
        out.put("xml_sha256", sha256(f.xml()));
        List<Object> sizes = new ArrayList<>();
        List<Object> hashes = new ArrayList<>();
        for (byte[] chunk : f.chunks()) {
            sizes.add((long) chunk.length);
            hashes.add(sha256(chunk));
        }
        out.put("chunks", sizes);
        out.put("chunks_sha256", hashes);
        return out;
    }

    static Outcome run(Map<String, Object> c, List<byte[]> pieces, boolean drain) {
        FrameReader r = reader(c);
        List<Map<String, Object>> frames = new ArrayList<>();
        long fed = 0;
        try {
            for (byte[] piece : pieces) {
                r.feed(piece);
                fed += piece.length;
                Frame f;
                while (drain && (f = r.next()) != null) {
                    frames.add(describe(f));
                }
            }
            r.feedEof();
            Frame f;
            while ((f = r.next()) != null) {
                frames.add(describe(f));
            }
        } catch (RemoteProtocolException e) {
            assertSame(e, assertThrows(RemoteProtocolException.class, r::next)); // OA-FRAME-9
            return new Outcome(frames, e.code().name(), fed);
        }
        return new Outcome(frames, "ok", fed);
    }

    static byte[] data(Map<String, Object> c) {
        return Vectors.bytes("frames", (String) c.get("file"));
    }

    static void check(Map<String, Object> c, Outcome got) {
        Map<String, Object> exp = Vectors.map(c.get("expected"));
        if (exp.containsKey("error")) {
            assertEquals(exp.get("error"), got.end);
            assertEquals(((Number) exp.get("after_frames")).intValue(), got.frames.size());
            assertEquals(exp.get("frames"), got.frames);
        } else {
            assertEquals("ok".equals(exp.get("then")) ? "ok" : "FRAME_TRUNCATED", got.end);
            assertEquals(exp.get("frames"), got.frames);
        }
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("cases")
    void whole(String name, Map<String, Object> c) {
        check(c, run(c, List.of(data(c)), true));
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("cases")
    void byteAtATime(String name, Map<String, Object> c) {
        byte[] data = data(c);
        List<byte[]> pieces = new ArrayList<>();
        for (byte b : data) {
            pieces.add(new byte[] {b});
        }
        Outcome got = run(c, pieces, true);
        check(c, got);
        Map<String, Object> exp = Vectors.map(c.get("expected"));
        if (exp.containsKey("error_by")) { // OA-FRAME-6, OA-FRAME-7: reported no later than this
            long by = ((Number) exp.get("error_by")).longValue();
            assertTrue(got.fed <= by, "reported after " + got.fed + " bytes, expected " + by);
            if (!"FRAME_UNKNOWN_TAG".equals(exp.get("error"))) {
                assertEquals(by, got.fed);
            }
        }
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("cases")
    void randomSplits(String name, Map<String, Object> c) {
        byte[] data = data(c);
        int[] sizes = {1, 2, 3, 5, 8, 11, 12, 13, 64, 300, 4096};
        for (int seed = 0; seed < 3; seed++) {
            Random rng = new Random(name.hashCode() * 31L + seed);
            List<byte[]> pieces = new ArrayList<>();
            for (int at = 0; at < data.length; ) {
                int size = Math.min(sizes[rng.nextInt(sizes.length)], data.length - at);
                pieces.add(java.util.Arrays.copyOfRange(data, at, at + size));
                at += size;
            }
            check(c, run(c, pieces, true));
        }
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("cases")
    void eofBeforeTakingFrames(String name, Map<String, Object> c) {
        check(c, run(c, List.of(data(c)), false)); // complete frames stay available after EOF
    }

    @Test
    void encodeRoundTrips() {
        byte[] xml = "<message><type>A</type></message>".getBytes();
        Frame f = new Frame(Frame.Tag.MESSAGE, xml, List.of());
        FrameReader r = new FrameReader();
        r.feed(f.encode());
        Frame back = r.next();
        assertEquals(Frame.Tag.MESSAGE, back.tag());
        assertEquals(new String(xml), new String(back.xml()));
        assertEquals(null, r.next());
    }
}
