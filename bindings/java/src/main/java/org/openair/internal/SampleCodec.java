package org.openair.internal;

import java.nio.ByteBuffer;
import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.List;
import org.openair.ApiMisuseException;
import org.openair.DataSample;
import org.openair.ErrorCode;
import org.openair.RemoteProtocolException;

/**
 * The datasample chunk (spec 11.2, OA-STREAM-2, OA-STREAM-10), without I/O: the payload length N
 * (uint32 little-endian), N payload bytes, the ASCII parameter string
 * {@code key%equals%value%sep%…} and one NUL.
 *
 * <p>Decoding never copies the payload: the sample views a slice of the chunk. Encoding returns
 * the three parts ({@link Parts}) so that a writer can send the payload from the caller's buffer.
 *
 * <p>Because {@code %} opens and closes both separators, a key or value next to a separator could
 * run into it; besides holding neither separator, a key must not end with {@code %sep} or
 * {@code %equals} and a value must not be {@code sep}, start with {@code sep%} or end with
 * {@code %sep}. With these rules decoding is the exact inverse of encoding.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class SampleCodec {
    /** The pair separator. */
    public static final String SEP = "%sep%";
    /** The key/value separator. */
    public static final String EQ = "%equals%";
    /** The default limit on the number of parameters a receiver reads. */
    public static final int MAX_PARAMS = 4096;
    /** Chunks smaller than this are written as one array (one write, one packet). */
    static final int JOIN_BELOW = 16 * 1024;

    private SampleCodec() {}

    /**
     * A chunk in three parts: length, payload (the sample's own view), parameters + NUL.
     *
     * @param length the 4 length bytes
     * @param payload the sample whose payload is sent as it is
     * @param tail the parameter string and the NUL
     */
    public record Parts(byte[] length, DataSample payload, byte[] tail) {
        /** @return the chunk's size in bytes */
        public long size() {
            return 4L + payload.size() + tail.length;
        }

        /** @return the whole chunk as one new array (copies the payload) */
        public byte[] join() {
            byte[] out = new byte[(int) size()];
            System.arraycopy(length, 0, out, 0, 4);
            payload.payload().get(out, 4, payload.size());
            System.arraycopy(tail, 0, out, 4 + payload.size(), tail.length);
            return out;
        }
    }

    /**
     * Return why ({@code key}, {@code value}) cannot be a parameter, or null (OA-STREAM-2).
     *
     * @param key the key
     * @param value the value
     * @return the problem, or null
     */
    public static String problem(String key, String value) {
        if (key.isEmpty()) {
            return "empty key";
        }
        for (String[] tv : new String[][] {{key, "key"}, {value, "value"}}) {
            String text = tv[0];
            for (int i = 0; i < text.length(); i++) {
                char c = text.charAt(i);
                if (c > 0x7F) {
                    return tv[1] + " '" + text + "' is not ASCII";
                }
                if (c == 0) {
                    return tv[1] + " holds a NUL";
                }
            }
            if (text.contains(SEP) || text.contains(EQ)) {
                return tv[1] + " '" + text + "' holds a separator (%sep% or %equals%)";
            }
        }
        if (key.endsWith("%sep") || key.endsWith("%equals")) {
            return "key '" + key + "' ends with '%sep' or '%equals'";
        }
        if (value.equals("sep") || value.startsWith("sep%") || value.endsWith("%sep")) {
            return "value '" + value + "' is 'sep', starts with 'sep%' or ends with '%sep'";
        }
        return null;
    }

    /**
     * Return the parameter string of {@code params} (without the NUL).
     *
     * @param params the parameters
     * @return the ASCII bytes
     * @throws ApiMisuseException for a parameter OA-STREAM-2 does not allow
     */
    public static byte[] encodeParams(List<DataSample.Param> params) {
        StringBuilder sb = new StringBuilder();
        for (DataSample.Param p : params) {
            String why = problem(p.key(), p.value()); // OA-STREAM-2
            if (why != null) {
                throw new ApiMisuseException("sample parameter: " + why);
            }
            if (sb.length() > 0) {
                sb.append(SEP);
            }
            sb.append(p.key()).append(EQ).append(p.value());
        }
        return sb.toString().getBytes(StandardCharsets.US_ASCII);
    }

    /**
     * Return the chunk of {@code sample} in three parts (the payload is not copied).
     *
     * @param sample the sample
     * @return the parts
     */
    public static Parts parts(DataSample sample) {
        int n = sample.size(); // an int: always below the uint32 limit of OA-STREAM-2
        byte[] length = {(byte) n, (byte) (n >>> 8), (byte) (n >>> 16), (byte) (n >>> 24)};
        byte[] params = encodeParams(sample.params());
        byte[] tail = new byte[params.length + 1];
        System.arraycopy(params, 0, tail, 0, params.length); // tail[last] = NUL
        return new Parts(length, sample, tail);
    }

    /**
     * Return the chunk of {@code sample} as one array.
     *
     * @param sample the sample
     * @return the chunk
     */
    public static byte[] encode(DataSample sample) {
        return parts(sample).join();
    }

    /**
     * Decode a chunk; the payload is a read-only view of {@code chunk} (not copied).
     *
     * @param chunk the chunk (not changed afterwards by the caller)
     * @return the sample
     * @throws RemoteProtocolException SAMPLE_INVALID (OA-STREAM-10)
     */
    public static DataSample decode(byte[] chunk) {
        return decode(ByteBuffer.wrap(chunk), MAX_PARAMS);
    }

    /**
     * Decode the chunk held by {@code chunk}'s remaining bytes.
     *
     * @param chunk the chunk
     * @param maxParams the most parameters read
     * @return the sample, its payload a read-only view of {@code chunk}
     * @throws RemoteProtocolException SAMPLE_INVALID (OA-STREAM-10)
     */
    public static DataSample decode(ByteBuffer chunk, int maxParams) {
        ByteBuffer view = chunk.slice();
        int total = view.remaining();
        if (total < 5) { // OA-STREAM-10: the length field and the NUL
            throw invalid("datasample chunk of " + total + " bytes is shorter than 5 bytes");
        }
        long n = (view.get(0) & 0xFFL) | (view.get(1) & 0xFFL) << 8 | (view.get(2) & 0xFFL) << 16
                | (view.get(3) & 0xFFL) << 24;
        if (n > total - 5) { // OA-STREAM-10: shorter than 5 + N
            throw invalid("datasample chunk of " + total + " bytes is too short for its payload"
                    + " length " + n);
        }
        if (view.get(total - 1) != 0) { // OA-STREAM-10: the last byte is NUL
            throw invalid("datasample chunk does not end with a NUL byte");
        }
        int start = 4 + (int) n;
        byte[] params = new byte[total - 1 - start];
        view.get(start, params);
        ByteBuffer payload = view.slice(4, (int) n);
        return new DataSample(payload, decodeParams(params, maxParams));
    }

    /**
     * Decode a parameter string (without the NUL).
     *
     * @param data the bytes
     * @param maxParams the most pairs read
     * @return the pairs
     * @throws RemoteProtocolException SAMPLE_INVALID (OA-STREAM-10)
     */
    public static List<DataSample.Param> decodeParams(byte[] data, int maxParams) {
        for (byte b : data) {
            if (b < 0) { // OA-STREAM-10: ASCII only
                throw invalid("sample parameters are not ASCII");
            }
            if (b == 0) { // OA-STREAM-2: one NUL, at the very end
                throw invalid("sample parameters hold a NUL before the last byte");
            }
        }
        String text = new String(data, StandardCharsets.US_ASCII);
        List<DataSample.Param> out = new ArrayList<>();
        if (text.isEmpty()) {
            return out;
        }
        int at = 0;
        while (true) {
            int end = text.indexOf(SEP, at);
            String pair = end < 0 ? text.substring(at) : text.substring(at, end);
            if (out.size() >= maxParams) {
                throw invalid("more than " + maxParams + " sample parameters");
            }
            out.add(pair(pair));
            if (end < 0) {
                return out;
            }
            at = end + SEP.length();
        }
    }

    private static DataSample.Param pair(String pair) {
        int eq = pair.indexOf(EQ);
        if (eq < 0) { // OA-STREAM-10: a list of key%equals%value pairs
            throw invalid("sample parameter '" + clip(pair) + "' has no %equals%");
        }
        String key = pair.substring(0, eq);
        String value = pair.substring(eq + EQ.length());
        String why = problem(key, value); // OA-STREAM-10
        if (why != null) {
            throw invalid("sample parameter: " + why);
        }
        return new DataSample.Param(key, value);
    }

    private static String clip(String s) {
        return s.length() <= 80 ? s : s.substring(0, 80);
    }

    private static RemoteProtocolException invalid(String detail) {
        return new RemoteProtocolException(ErrorCode.SAMPLE_INVALID, detail);
    }
}
