package org.openair.internal;

import java.nio.charset.StandardCharsets;
import java.util.List;
import java.util.Map;
import java.util.function.BiFunction;
import java.util.regex.Pattern;
import org.openair.Message;

/**
 * Test only: library faults for the deliberately broken conformance shim
 * ({@code org.openair.shim.BrokenShimMain}). Each fault installs a rewrite of the frames the
 * library sends through the package-private test seam {@link Session#tap}, so that the library
 * puts on the wire exactly what a library with that defect would. This class lives in
 * src/test/java: it is never part of {@code openair.jar} or {@code openair-shim.jar}, and nothing
 * in the library assigns the seam.
 *
 * <p>Threading: {@link #install} once, before the library starts; the rewrites then run on the
 * library's connection threads.
 */
public final class FrameFaults {
    private static final Pattern POSTED_TIME = Pattern.compile("(</?)postedTime\\b");

    /** A fault: the bytes to send for a message the library is about to send as {@code frame}. */
    private interface Fault {
        byte[] rewrite(Message message, Frame.Tag tag, byte[] frame);
    }

    private static final Map<String, Fault> FAULTS = Map.of(
            "lowercase-postedtime", FrameFaults::lowercasePostedTime,
            "no-posted-time", (m, tag, frame) -> m.posted() == null ? frame
                    : encode(m.toBuilder().posted(null).build(), tag),
            "ping-accept", answered("PING_SUCCESS", (m, tag) ->
                    encode(m.toBuilder().type("RECEIVE_ACCEPT").build(), tag)),
            "no-ack", answered("RECEIVE_ACCEPT", (m, tag) -> new byte[0]),
            "wrong-isresponse", answered("RECEIVE_ACCEPT", (m, tag) ->
                    encode(m.toBuilder().isresponse(Message.newId()).build(), tag)),
            "noreply-to-legacy", FrameFaults::noreplyToMarked,
            "crash-on-malformed", answered("RECEIVE_ERROR", (m, tag) -> {
                Runtime.getRuntime().halt(3); // dies the moment it would answer RECEIVE_ERROR
                return new byte[0];
            }),
            "accept-malformed", answered("RECEIVE_ERROR", (m, tag) ->
                    encode(m.toBuilder().type("RECEIVE_ACCEPT").build(), tag)),
            // Streams: ADD_SAMPLE without binarysizes (its chunk still follows the XML).
            "add-sample-no-binarysizes", (m, tag, frame) -> m.type().equals("ADD_SAMPLE")
                    ? withoutSizes(frame) : frame,
            // Streams: never acknowledge a pushed DATASAMPLE (answered on a push connection's
            // reader thread, openair-<module>-push-<stream>; registration samples still are).
            "push-no-ack", (m, tag, frame) -> m.type().equals("RECEIVE_ACCEPT")
                    && Thread.currentThread().getName().contains("-push-") ? new byte[0] : frame);

    private static volatile String markedType;

    private FrameFaults() {}

    /** @return the names {@link #install} accepts, sorted */
    public static List<String> names() {
        return FAULTS.keySet().stream().sorted().toList();
    }

    /**
     * Break the library in this process: every frame it sends from now on passes through the
     * fault called {@code name}.
     *
     * @param name one of {@link #names()}
     * @return false (and nothing installed) when there is no such fault
     */
    public static boolean install(String name) {
        Fault fault = FAULTS.get(name);
        if (fault == null) {
            return false;
        }
        Session.tap = fault::rewrite;
        return true;
    }

    /**
     * For {@code noreply-to-legacy}: the next request of this type is sent with
     * {@code noreply="yes"}, whatever the server advertised (the library itself then posts it as
     * an ordinary request, OA-GEN-2).
     *
     * @param type the type of the post about to be made
     */
    public static void markNoReply(String type) {
        markedType = type;
    }

    private static byte[] encode(Message m, Frame.Tag tag) {
        return new Frame(tag, Codec.encode(m), m.binary()).encode();
    }

    /**
     * A fault that rewrites only the messages of type {@code type}: the library sends
     * PING_SUCCESS, RECEIVE_ACCEPT and RECEIVE_ERROR only as answers to the server's requests.
     */
    private static Fault answered(String type, BiFunction<Message, Frame.Tag, byte[]> rewrite) {
        return (m, tag, frame) -> m.type().equals(type) ? rewrite.apply(m, tag) : frame;
    }

    /** Drop binarysizes from the XML of a frame head (the library writes the chunks next). */
    private static byte[] withoutSizes(byte[] head) {
        String xml = new String(head, FrameReader.HEADER_SIZE, head.length
                - FrameReader.HEADER_SIZE, StandardCharsets.UTF_8)
                .replaceAll("<binarysizes>[^<]*</binarysizes><totalbinarysize>[^<]*"
                        + "</totalbinarysize>", "");
        return new Frame(Frame.Tag.MESSAGE, xml.getBytes(StandardCharsets.UTF_8), List.of())
                .encode();
    }

    private static byte[] lowercasePostedTime(Message m, Frame.Tag tag, byte[] frame) {
        String xml = new String(Codec.encode(m), StandardCharsets.UTF_8);
        String legacy = POSTED_TIME.matcher(xml).replaceAll("$1postedtime");
        return new Frame(tag, legacy.getBytes(StandardCharsets.UTF_8), m.binary()).encode();
    }

    private static byte[] noreplyToMarked(Message m, Frame.Tag tag, byte[] frame) {
        String marked = markedType;
        if (marked == null || !marked.equals(m.type()) || m.noreply()) {
            return frame;
        }
        markedType = null;
        return encode(m.toBuilder().noreply(true).build(), tag);
    }
}
