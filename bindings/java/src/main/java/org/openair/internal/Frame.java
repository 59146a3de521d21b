package org.openair.internal;

import java.util.List;

/**
 * One frame (spec 2.1). MESSAGE/RECEIVE: {@code xml} is the message's XML and {@code chunks} the
 * binary chunks after it (OA-FRAME-4). BINARY: {@code xml} is empty and {@code chunks} holds the
 * one chunk (OA-FRAME-5).
 *
 * <p>Threading: treat as immutable once built (the arrays are not copied, for speed).
 *
 * @param tag the frame's tag
 * @param xml the XML bytes
 * @param chunks the binary chunks
 */
public record Frame(Tag tag, byte[] xml, List<byte[]> chunks) {

    /** The three frame tags (OA-FRAME-2), compared byte for byte. */
    public enum Tag {
        /** A message. */
        MESSAGE("Message"),
        /** The callback notification (OA-FRAME-10). */
        RECEIVE("Receive"),
        /** One datasample chunk (OA-FRAME-5). */
        BINARY("BinaryM");

        private final String wire;

        Tag(String wire) {
            this.wire = wire;
        }

        /** @return the tag as it travels */
        public String wire() {
            return wire;
        }
    }

    /* Copy the chunk list. */
    public Frame {
        chunks = List.copyOf(chunks);
    }

    /**
     * Encode the frame: the 7-byte tag, a NUL, the length as a little-endian uint32, the body
     * and the chunks (OA-FRAME-1, OA-FRAME-3).
     *
     * @return the bytes
     */
    public byte[] encode() {
        byte[] body = tag == Tag.BINARY ? chunks.get(0) : xml;
        long total = FrameReader.HEADER_SIZE + (long) body.length;
        if (tag != Tag.BINARY) {
            for (byte[] c : chunks) {
                total += c.length;
            }
        }
        if (total > Integer.MAX_VALUE - 16) {
            throw new org.openair.ApiMisuseException("a frame of " + total + " bytes is too big");
        }
        byte[] out = new byte[(int) total];
        byte[] name = tag.wire().getBytes(java.nio.charset.StandardCharsets.US_ASCII);
        System.arraycopy(name, 0, out, 0, 7);
        out[7] = 0;
        int len = body.length;
        out[8] = (byte) len;
        out[9] = (byte) (len >>> 8);
        out[10] = (byte) (len >>> 16);
        out[11] = (byte) (len >>> 24);
        int at = FrameReader.HEADER_SIZE;
        System.arraycopy(body, 0, out, at, len);
        at += len;
        if (tag != Tag.BINARY) {
            for (byte[] c : chunks) {
                System.arraycopy(c, 0, out, at, c.length);
                at += c.length;
            }
        }
        return out;
    }
}
