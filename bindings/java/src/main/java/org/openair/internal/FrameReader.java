package org.openair.internal;

import java.math.BigInteger;
import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.List;
import org.openair.ApiMisuseException;
import org.openair.ErrorCode;
import org.openair.OpenAirException;
import org.openair.RemoteProtocolException;
import org.w3c.dom.Element;

/**
 * Cuts a byte stream into frames, incrementally and without I/O (spec section 2, OA-FRAME-11).
 *
 * <p>{@link #feed} bytes as they arrive, then call {@link #next()} until it returns null. Limits are
 * checked as soon as the header (or the XML, for {@code binarysizes}) is complete, before any more
 * of the frame is awaited (OA-FRAME-7). The first framing error is sticky (OA-FRAME-9): every later
 * call throws it again and no later byte is kept. The frame deadline (OA-FRAME-12) belongs to the
 * socket adapter, which watches {@link #inFrame()}.
 *
 * <p>Threading: not thread-safe; one reader per connection, used by one thread.
 */
public final class FrameReader {
    /** The 7-byte tag, the NUL and the uint32 length (OA-FRAME-1). */
    public static final int HEADER_SIZE = 12;
    /** The default XML limit (OA-LIM-1). */
    public static final long DEFAULT_MAX_XML = 16L * 1024 * 1024;
    /** The default binary limit (OA-LIM-2). */
    public static final long DEFAULT_MAX_BINARY = 64L * 1024 * 1024;
    /** Java arrays cannot hold more than this, whatever the configured limit. */
    private static final long ARRAY_MAX = Integer.MAX_VALUE - 64;
    private static final int MAX_SIZE_DIGITS = 4000;
    private static final byte[][] TAGS = {
        "Message\0".getBytes(StandardCharsets.US_ASCII),
        "Receive\0".getBytes(StandardCharsets.US_ASCII),
        "BinaryM\0".getBytes(StandardCharsets.US_ASCII),
    };
    private static final Frame.Tag[] TAG_VALUES = {
        Frame.Tag.MESSAGE, Frame.Tag.RECEIVE, Frame.Tag.BINARY
    };
    private static final byte[] MARKER = "binarysizes".getBytes(StandardCharsets.US_ASCII);

    private final long maxXml;
    private final long maxBinary;
    private final int maxDepth;
    private byte[] buf = new byte[8192];
    private int pos; // start of the current frame; bytes before it are consumed
    private int end; // end of the received bytes
    private Frame.Tag tag; // set once the current frame's header is valid
    private long[] sizes; // set once its chunk sizes are known
    private Frame pending; // a complete frame feedEof found ahead of time
    private boolean eof;
    private RemoteProtocolException error;

    /** A reader with the default limits. */
    public FrameReader() {
        this(DEFAULT_MAX_XML, DEFAULT_MAX_BINARY, SafeXml.DEFAULT_MAX_DEPTH);
    }

    /**
     * A reader with the given limits.
     *
     * @param maxXml the largest L of a Message/Receive frame (OA-LIM-1)
     * @param maxBinary the largest chunk total or BinaryM length (OA-LIM-2)
     * @param maxDepth the depth limit for the {@code binarysizes} lookup (OA-LIM-3)
     */
    public FrameReader(long maxXml, long maxBinary, int maxDepth) {
        if (maxXml < 0 || maxBinary < 0) {
            throw new ApiMisuseException("frame limits must not be negative");
        }
        this.maxXml = Math.min(maxXml, ARRAY_MAX);
        this.maxBinary = Math.min(maxBinary, ARRAY_MAX);
        this.maxDepth = maxDepth;
    }

    /** @return the sticky framing error, or null while the stream is sound */
    public RemoteProtocolException error() {
        return error;
    }

    /** @return how many received bytes have not been returned as part of a frame yet */
    public long buffered() {
        long held = end - pos;
        if (pending != null) {
            held += frameSize(pending);
        }
        return held;
    }

    /** @return true while bytes of an unfinished frame are held (meaningful after next()) */
    public boolean inFrame() {
        return error == null && buffered() > 0;
    }

    /**
     * Append received bytes.
     *
     * @param data the bytes
     * @param off where they start
     * @param len how many
     * @throws RemoteProtocolException the sticky error, once the stream has failed
     */
    public void feed(byte[] data, int off, int len) {
        raiseIfFailed();
        if (eof) {
            throw new ApiMisuseException("feed after feedEof");
        }
        if (end + len > buf.length) {
            compactOrGrow(len);
        }
        System.arraycopy(data, off, buf, end, len);
        end += len;
    }

    /**
     * Append received bytes.
     *
     * @param data the bytes
     */
    public void feed(byte[] data) {
        feed(data, 0, data.length);
    }

    /**
     * Return the next complete frame, or null until more bytes arrive.
     *
     * @return the frame or null
     * @throws RemoteProtocolException FRAME_UNKNOWN_TAG, FRAME_TOO_LARGE, BINARY_TOO_LARGE,
     *     BINARY_SIZES_INVALID (and FRAME_TRUNCATED after feedEof); each is sticky
     */
    public Frame next() {
        raiseIfFailed();
        Frame frame = pending;
        pending = null;
        if (frame == null) {
            frame = advanceOrFail();
        }
        if (frame == null && eof && buffered() > 0) {
            throw fail(truncated());
        }
        return frame;
    }

    /**
     * Signal the end of the stream. Complete frames still buffered stay available from
     * {@link #next()}; a partial frame is FRAME_TRUNCATED (OA-FRAME-8), reported here when no
     * complete frame is pending, else once they have been taken.
     */
    public void feedEof() {
        raiseIfFailed();
        eof = true;
        if (pending == null) {
            pending = advanceOrFail();
        }
        if (pending == null && buffered() > 0) {
            throw fail(truncated());
        }
    }

    private RemoteProtocolException truncated() {
        return new RemoteProtocolException(ErrorCode.FRAME_TRUNCATED,
                buffered() + " bytes of an unfinished frame");
    }

    private void raiseIfFailed() {
        if (error != null) {
            throw error; // the same error every time (OA-FRAME-9)
        }
    }

    private RemoteProtocolException fail(RemoteProtocolException e) {
        error = e;
        buf = new byte[0]; // OA-FRAME-8, OA-FRAME-9: every held byte is dropped
        pos = 0;
        end = 0;
        pending = null;
        return e;
    }

    private Frame advanceOrFail() {
        try {
            return advance();
        } catch (RemoteProtocolException e) {
            throw fail(e);
        }
    }

    private Frame advance() {
        int avail = end - pos;
        if (tag == null && !readHeader(avail)) {
            return null;
        }
        long length = length();
        if (avail < HEADER_SIZE + length) {
            return null;
        }
        if (sizes == null) {
            sizes = readSizes((int) length);
        }
        long total = HEADER_SIZE + length;
        for (long s : sizes) {
            total += s;
        }
        if (avail < total) {
            return null;
        }
        return take((int) length, (int) total);
    }

    private boolean readHeader(int avail) {
        int have = Math.min(avail, 8);
        int found = -1;
        boolean possible = false;
        for (int t = 0; t < TAGS.length; t++) {
            if (Arrays.equals(buf, pos, pos + have, TAGS[t], 0, have)) {
                possible = true;
                if (have == 8) {
                    found = t;
                }
            }
        }
        if (!possible) { // refuse as soon as the bytes cannot start a tag (OA-FRAME-2, OA-FRAME-6)
            String shown = new String(buf, pos, have, StandardCharsets.ISO_8859_1);
            throw new RemoteProtocolException(ErrorCode.FRAME_UNKNOWN_TAG,
                    "frame header starts '" + shown.replace("\0", "\\0") + "'");
        }
        if (found < 0 || avail < HEADER_SIZE) {
            return false;
        }
        Frame.Tag t = TAG_VALUES[found];
        long length = uint32(pos + 8); // OA-FRAME-1
        if (t == Frame.Tag.BINARY && length > maxBinary) { // OA-FRAME-7, OA-LIM-2
            throw new RemoteProtocolException(ErrorCode.BINARY_TOO_LARGE,
                    "BinaryM chunk of " + length + " bytes exceeds " + maxBinary);
        }
        if (t != Frame.Tag.BINARY && length > maxXml) { // OA-FRAME-7, OA-LIM-1
            throw new RemoteProtocolException(ErrorCode.FRAME_TOO_LARGE,
                    "XML of " + length + " bytes exceeds " + maxXml);
        }
        tag = t;
        return true;
    }

    private long uint32(int at) {
        return (buf[at] & 0xffL) | (buf[at + 1] & 0xffL) << 8 | (buf[at + 2] & 0xffL) << 16
                | (buf[at + 3] & 0xffL) << 24;
    }

    private long length() {
        return uint32(pos + 8);
    }

    private long[] readSizes(int length) {
        if (tag == Frame.Tag.BINARY) {
            return new long[0]; // the body is the chunk (OA-FRAME-5)
        }
        byte[] xml = Arrays.copyOfRange(buf, pos + HEADER_SIZE, pos + HEADER_SIZE + length);
        long[] found = binarySizes(xml, maxDepth); // OA-FRAME-4, OA-FRAME-13
        long sum = 0;
        for (long s : found) {
            if (s > maxBinary - sum) { // OA-FRAME-7, OA-LIM-2: refused before any chunk is read
                throw new RemoteProtocolException(ErrorCode.BINARY_TOO_LARGE,
                        "binarysizes total exceeds " + maxBinary);
            }
            sum += s;
        }
        return found;
    }

    private Frame take(int length, int total) {
        Frame.Tag t = tag;
        int at = pos + HEADER_SIZE;
        byte[] body = Arrays.copyOfRange(buf, at, at + length);
        at += length;
        List<byte[]> chunks = new ArrayList<>(sizes.length);
        for (long size : sizes) {
            chunks.add(Arrays.copyOfRange(buf, at, at + (int) size));
            at += (int) size;
        }
        pos += total;
        tag = null;
        sizes = null;
        if (pos == end) {
            pos = 0;
            end = 0;
        }
        if (t == Frame.Tag.BINARY) {
            return new Frame(t, new byte[0], List.of(body));
        }
        return new Frame(t, body, chunks);
    }

    private void compactOrGrow(int len) {
        int held = end - pos;
        long need = (long) held + len;
        if (need > Integer.MAX_VALUE - 64) {
            throw new ApiMisuseException("the frame buffer cannot grow beyond 2 GiB");
        }
        byte[] target = need <= buf.length ? buf : new byte[(int) Math.max(need, Math.min(
                (long) buf.length * 2, Integer.MAX_VALUE - 64))];
        System.arraycopy(buf, pos, target, 0, held);
        buf = target;
        pos = 0;
        end = held;
    }

    private static long frameSize(Frame f) {
        if (f.tag() == Frame.Tag.BINARY) {
            return HEADER_SIZE + f.chunks().get(0).length;
        }
        long n = HEADER_SIZE + f.xml().length;
        for (byte[] c : f.chunks()) {
            n += c.length;
        }
        return n;
    }

    // --------------------------------------------------------------------- binarysizes

    /**
     * Return the chunk sizes a message's {@code binarysizes} slot announces (OA-FRAME-4).
     *
     * <p>Only a direct child of a {@code <message>} root counts, names compared in any case. XML
     * that cannot be parsed, or whose root is not {@code message}, announces no chunk
     * (OA-FRAME-13); so does a message without the slot, whose {@code totalbinarysize} is then not
     * looked at.
     *
     * @param xml the message's XML
     * @param maxDepth the depth limit of the parse
     * @return the sizes
     * @throws RemoteProtocolException BINARY_SIZES_INVALID for a slot that is not a list of
     *     non-negative integers, a repeated slot, or a total that is not their sum;
     *     BINARY_TOO_LARGE for a size of more than 4000 digits
     */
    public static long[] binarySizes(byte[] xml, int maxDepth) {
        if (!containsMarker(xml)) {
            return new long[0]; // fast path: no slot can exist
        }
        Element root;
        try {
            root = SafeXml.parse(xml, Math.max(xml.length, SafeXml.DEFAULT_MAX_BYTES), maxDepth);
        } catch (OpenAirException e) {
            return new long[0]; // OA-FRAME-13
        }
        if (!Dom.name(root).equals("message")) {
            return new long[0]; // XML_MALFORMED (OA-MSG-1), so OA-FRAME-13 applies
        }
        String sizesText = slotText(root, "binarysizes");
        if (sizesText == null) {
            return new long[0];
        }
        String totalText = slotText(root, "totalbinarysize");
        List<String> digits = sizeList(sizesText);
        String total = totalText == null ? null : sizeValue(totalText, totalText);
        BigInteger sum = BigInteger.ZERO;
        long[] out = new long[digits.size()];
        for (int i = 0; i < out.length; i++) {
            BigInteger value = toInt(digits.get(i));
            sum = sum.add(value);
            out[i] = value.bitLength() < 63 ? value.longValue() : Long.MAX_VALUE;
        }
        if (total != null && !stripZeros(total).equals(stripZeros(sum.toString()))) {
            throw sizesInvalid("totalbinarysize " + clip(total) + " is not the sum of "
                    + clip(sizesText)); // OA-FRAME-4
        }
        return out;
    }

    private static boolean containsMarker(byte[] xml) {
        outer:
        for (int i = 0; i + MARKER.length <= xml.length; i++) {
            for (int j = 0; j < MARKER.length; j++) {
                int c = xml[i + j];
                if (c >= 'A' && c <= 'Z') {
                    c += 32;
                }
                if (c != MARKER[j]) {
                    continue outer;
                }
            }
            return true;
        }
        return false;
    }

    private static String slotText(Element root, String name) {
        Element found = null;
        int count = 0;
        for (Element child : Dom.children(root)) {
            if (Dom.name(child).equals(name)) {
                found = child;
                count++;
            }
        }
        if (found == null) {
            return null;
        }
        if (count > 1) {
            throw sizesInvalid(count + " " + name + " slots"); // OA-FRAME-4
        }
        if (Dom.hasElements(found)) {
            throw sizesInvalid(name + " holds elements, not a number list");
        }
        return Dom.innerText(found);
    }

    private static List<String> sizeList(String text) {
        List<String> out = new ArrayList<>();
        if (Dom.isBlank(text)) {
            return out; // an empty slot: no chunk
        }
        for (String part : text.split(",", -1)) {
            out.add(sizeValue(part, text));
        }
        return out;
    }

    private static String sizeValue(String text, String whole) {
        String value = Dom.strip(text);
        if (value.isEmpty() || !value.chars().allMatch(c -> c >= '0' && c <= '9')) {
            throw sizesInvalid(clip(whole) + " is not a list of non-negative integers");
        }
        return value;
    }

    private static BigInteger toInt(String digits) {
        String significant = stripZeros(digits);
        if (significant.length() > MAX_SIZE_DIGITS) { // OA-FRAME-7
            throw new RemoteProtocolException(ErrorCode.BINARY_TOO_LARGE,
                    "a chunk size of " + significant.length() + " digits");
        }
        return significant.isEmpty() ? BigInteger.ZERO : new BigInteger(significant);
    }

    private static String stripZeros(String digits) {
        int i = 0;
        while (i < digits.length() && digits.charAt(i) == '0') {
            i++;
        }
        return digits.substring(i);
    }

    private static String clip(String text) {
        return text.length() <= 60 ? "'" + text + "'" : "'" + text.substring(0, 60) + "'...";
    }

    private static RemoteProtocolException sizesInvalid(String detail) {
        return new RemoteProtocolException(ErrorCode.BINARY_SIZES_INVALID, detail);
    }
}
