package org.openair.internal;

import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.OptionalLong;
import java.util.regex.Pattern;
import org.openair.ApiMisuseException;
import org.openair.DataSample;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.ReceivedSample;
import org.openair.RemoteProtocolException;
import org.openair.Slot;
import org.openair.StreamAlarm;
import org.openair.StreamInfo;
import org.w3c.dom.Element;

/**
 * Stream requests and replies as values, without I/O (spec section 11): media commands, their
 * contents, and the readers of DATASAMPLE, DATASAMPLES, DATA_ACCEPTED, TIMESTAMP, COUNT, INFO,
 * STREAMS and alarm posts. A reply without the shape the spec gives is CONTENT_INVALID (or
 * SAMPLE_INVALID for a bad chunk).
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class StreamWire {
    /** The content of ADD_SAMPLE and of a DATASAMPLE reply. */
    public static final String DATASAMPLE_XML = "<datasample/>";
    /** The prefix of an alarm post's type (OA-XSTREAM-6). */
    public static final String ALARM_PREFIX = "AIR.Stream.Alarm.";
    private static final Pattern UINT = Pattern.compile("\\s*\\+?[0-9]{1,18}\\s*");

    private StreamWire() {}

    // ---------------------------------------------------------------------------- requests

    /**
     * A media command to the stream {@code target} (name or type) from {@code sender}.
     *
     * @param target the stream's name or type
     * @param sender the requester
     * @param type the command
     * @param content text content, or XML when {@code xml}
     * @param xml whether the content is XML
     * @return the request
     */
    public static Message request(String target, String sender, String type, String content,
            boolean xml) {
        Message.Builder b = Message.builder(type).sender(sender).to(target);
        return (xml ? b.xmlContent(content) : b.content(content)).build();
    }

    /**
     * ADD_SAMPLES content: an objectcollection of {@code count} datasample objects (OA-STREAM-5).
     *
     * @param count at least 1
     * @return the content
     */
    public static String addSamplesContent(int count) {
        if (count < 1) {
            throw new ApiMisuseException("ADD_SAMPLES needs at least one sample");
        }
        StringBuilder sb = new StringBuilder("<objectcollection>");
        for (int i = 0; i < count; i++) {
            sb.append("<object>").append(DATASAMPLE_XML).append("</object>");
        }
        return sb.append("</objectcollection>").toString();
    }

    /**
     * One time element {@code <time sec msec/>} for {@code ms} since the epoch.
     *
     * @param ms milliseconds since the epoch
     * @return the element
     */
    public static String timeContent(long ms) {
        return "<time sec=\"" + Math.floorDiv(ms, 1000) + "\" msec=\"" + Math.floorMod(ms, 1000)
                + "\"/>";
    }

    /**
     * GET_SAMPLES_BY_TIME content: two objects holding the bounds.
     *
     * @param fromMs first bound
     * @param untilMs last bound
     * @return the content
     */
    public static String rangeContent(long fromMs, long untilMs) {
        return "<objectcollection><object>" + timeContent(fromMs) + "</object><object>"
                + timeContent(untilMs) + "</object></objectcollection>";
    }

    /**
     * The type of a waiting command: its name, one space, the timeout in ms (spec 11.5).
     *
     * @param byId AFTERID rather than SAMPLE
     * @param last LAST rather than FIRST
     * @param timeoutMs the timeout
     * @return the type
     */
    public static String waitType(boolean byId, boolean last, long timeoutMs) {
        if (timeoutMs < 0) {
            throw new ApiMisuseException("a wait timeout must not be negative: " + timeoutMs);
        }
        return "WAIT_FOR_" + (last ? "LAST" : "FIRST") + "_" + (byId ? "AFTERID" : "SAMPLE") + " "
                + timeoutMs;
    }

    /**
     * SEARCH_SAMPLES content (OA-XSTREAM-9); times as epoch ms text.
     *
     * @param afterMs lower bound or null
     * @param untilMs upper bound or null
     * @param params key → glob
     * @param latest 0 for all
     * @return the content
     */
    public static String searchContent(Long afterMs, Long untilMs, Map<String, String> params,
            int latest) {
        if (latest < 0) {
            throw new ApiMisuseException("latest must not be negative: " + latest);
        }
        StringBuilder sb = new StringBuilder("<samplesearch>");
        if (afterMs != null) {
            sb.append("<afterTime>").append(afterMs).append("</afterTime>");
        }
        if (untilMs != null) {
            sb.append("<untilTime>").append(untilMs).append("</untilTime>");
        }
        for (Map.Entry<String, String> e : params.entrySet()) {
            sb.append("<param name=\"");
            XmlWriter.attrValue(e.getKey(), sb);
            sb.append("\">");
            XmlWriter.text(e.getValue(), sb);
            sb.append("</param>");
        }
        if (latest != 0) {
            sb.append("<latest>").append(latest).append("</latest>");
        }
        return sb.append("</samplesearch>").toString();
    }

    /**
     * LOCK_SAMPLES content: the range {@code first-last} (OA-XSTREAM-5).
     *
     * @param first first id
     * @param last last id
     * @return the content
     */
    public static String lockContent(long first, long last) {
        if (first < 0 || last < first) {
            throw new ApiMisuseException("a lock range needs 0 <= first <= last: " + first + "-"
                    + last);
        }
        return first + "-" + last;
    }

    // ----------------------------------------------------------------------------- replies

    private static RemoteProtocolException contentInvalid(String detail) {
        return new RemoteProtocolException(ErrorCode.CONTENT_INVALID, detail);
    }

    /**
     * Read the one sample of a DATASAMPLE message (a reply or a push, OA-STREAM-12).
     *
     * @param msg the message
     * @return the sample
     */
    public static DataSample sampleOf(Message msg) {
        if (msg.binaryCount() != 1) {
            throw new RemoteProtocolException(ErrorCode.SAMPLE_INVALID,
                    msg.type() + " carries " + msg.binaryCount() + " chunks, not 1");
        }
        return SampleCodec.decode(msg.binaryView(0), SampleCodec.MAX_PARAMS);
    }

    /**
     * Read a DATASAMPLES reply: one chunk per {@code <datasample>} element, oldest first.
     *
     * @param msg the reply
     * @return the samples
     */
    public static List<DataSample> samplesOf(Message msg) {
        int marked = 0;
        if (!Dom.isBlank(msg.content())) {
            Element root = root(msg.content(), "objectcollection");
            marked = root.getElementsByTagName("datasample").getLength();
        }
        if (marked != msg.binaryCount()) {
            throw contentInvalid(msg.type() + " names " + marked + " datasample(s) but carries "
                    + msg.binaryCount() + " chunk(s)");
        }
        List<DataSample> out = new ArrayList<>(marked);
        for (int i = 0; i < marked; i++) {
            out.add(SampleCodec.decode(msg.binaryView(i), SampleCodec.MAX_PARAMS));
        }
        return out;
    }

    /**
     * Read a decimal text reply (DATA_ACCEPTED id, COUNT, SIZE, LOCKED).
     *
     * @param msg the reply
     * @param what what the number is, for the error
     * @return the number
     */
    public static long integerOf(Message msg, String what) {
        if (!UINT.matcher(msg.content()).matches()) {
            throw contentInvalid(msg.type() + ": " + what + " '" + Codec.clip(msg.content())
                    + "' is not a count");
        }
        return Long.parseLong(Dom.strip(msg.content()).replace("+", ""));
    }

    /**
     * Read ADD_SAMPLES's DATA_ACCEPTED {@code <collection><entry>id</entry>…</collection>}.
     *
     * @param msg the reply
     * @return the ids
     */
    public static List<Long> idsOf(Message msg) {
        Element root = root(msg.content(), "collection");
        List<Long> ids = new ArrayList<>();
        for (Element child : Dom.children(root)) {
            String text = Dom.innerText(child);
            if (!Dom.name(child).equals("entry") || !UINT.matcher(text).matches()) {
                throw contentInvalid("DATA_ACCEPTED: bad collection entry <" + Dom.name(child)
                        + ">");
            }
            ids.add(Long.parseLong(Dom.strip(text).replace("+", "")));
        }
        return ids;
    }

    /**
     * Read a TIMESTAMP reply (one time element) as ms since the epoch.
     *
     * @param msg the reply
     * @return the time
     */
    public static long timestampOf(Message msg) {
        List<Element> roots = roots(msg.content());
        if (roots.size() != 1) {
            throw contentInvalid("TIMESTAMP must hold one time element");
        }
        try {
            return TimeXml.timeFromElement(roots.get(0)).toEpochMillis();
        } catch (RemoteProtocolException e) {
            throw contentInvalid("TIMESTAMP: " + e.detail());
        }
    }

    /**
     * Read an INFO reply.
     *
     * @param msg the reply
     * @return the info
     */
    public static StreamInfo infoOf(Message msg) {
        return info(root(msg.content(), "streaminfo"));
    }

    /**
     * Read a STREAMS reply: {@code <streams>} of {@code <streaminfo>}.
     *
     * @param msg the reply
     * @return the infos, in the server's order
     */
    public static List<StreamInfo> streamsOf(Message msg) {
        if (Dom.isBlank(msg.content())) {
            return List.of();
        }
        List<StreamInfo> out = new ArrayList<>();
        for (Element el : Dom.children(root(msg.content(), "streams"))) {
            out.add(info(el));
        }
        return out;
    }

    private static StreamInfo info(Element el) {
        if (!Dom.name(el).equals("streaminfo")) {
            throw contentInvalid("expected <streaminfo>, found <" + Dom.name(el) + ">");
        }
        Map<String, String> attrs = new LinkedHashMap<>();
        for (String a : Dom.attributeOrder(el)) {
            attrs.put(a, el.getAttribute(a));
        }
        String name = attrs.getOrDefault("name", "");
        if (name.isEmpty()) {
            throw contentInvalid("<streaminfo> without a name");
        }
        return new StreamInfo(name, attrs.getOrDefault("whiteboard", ""),
                attrs.getOrDefault("type", ""), num(attrs, "count"), num(attrs, "size"),
                optional(attrs, "oldest"), optional(attrs, "newest"), num(attrs, "maxsize"),
                num(attrs, "maxcount"), num(attrs, "subscribers"), num(attrs, "writers"),
                num(attrs, "locked"), attrs);
    }

    private static long num(Map<String, String> attrs, String key) {
        OptionalLong v = optional(attrs, key);
        return v.isPresent() ? v.getAsLong() : 0;
    }

    private static OptionalLong optional(Map<String, String> attrs, String key) {
        String text = attrs.get(key);
        if (text == null) {
            return OptionalLong.empty();
        }
        if (!UINT.matcher(text).matches()) {
            throw contentInvalid("<streaminfo " + key + "='" + Codec.clip(text)
                    + "'> is not an integer");
        }
        return OptionalLong.of(Long.parseLong(Dom.strip(text).replace("+", "")));
    }

    /**
     * Read a pushed DATASAMPLE, its {@code dropped} slot included (OA-STREAM-8).
     *
     * @param msg the message
     * @param receivedNanos its arrival time
     * @return the sample
     */
    public static ReceivedSample receivedOf(Message msg, long receivedNanos) {
        long dropped = 0;
        for (Slot s : msg.extras()) {
            if (Dom.fold(s.name()).equals("dropped")) {
                if (!UINT.matcher(s.value()).matches()) {
                    throw contentInvalid("dropped '" + Codec.clip(s.value()) + "' is not a count");
                }
                dropped = Long.parseLong(Dom.strip(s.value()).replace("+", ""));
                break;
            }
        }
        return new ReceivedSample(msg.sender(), sampleOf(msg), dropped, receivedNanos);
    }

    /**
     * Whether {@code msg} is a stream alarm post (OA-XSTREAM-6).
     *
     * @param msg the message
     * @return true for {@code AIR.Stream.Alarm.<Kind>}
     */
    public static boolean isAlarm(Message msg) {
        return msg.type().startsWith(ALARM_PREFIX) && msg.type().length() > ALARM_PREFIX.length();
    }

    /**
     * Read an alarm post: the kind from its type, the entries from its dictionary.
     *
     * @param msg the post
     * @return the alarm
     */
    public static StreamAlarm alarmOf(Message msg) {
        if (!isAlarm(msg)) {
            throw contentInvalid("'" + msg.type() + "' is not an alarm");
        }
        Map<String, String> entries = new LinkedHashMap<>();
        if (!Dom.isBlank(msg.content())) {
            for (Element child : Dom.children(root(msg.content(), "dictionary"))) {
                String key = Dom.attr(child, "name");
                if (!Dom.name(child).equals("entry") || key == null || Dom.hasElements(child)) {
                    throw contentInvalid("<dictionary> holds a bad <" + Dom.name(child) + ">");
                }
                entries.putIfAbsent(key, Dom.innerText(child));
            }
        }
        String stream = entries.getOrDefault("stream", "");
        return new StreamAlarm(msg.type().substring(ALARM_PREFIX.length()),
                stream.isEmpty() ? msg.sender() : stream, entries, msg);
    }

    private static List<Element> roots(String content) {
        try {
            return SafeXml.parseFragment(content, SafeXml.DEFAULT_MAX_DEPTH);
        } catch (OpenAirException e) {
            throw contentInvalid("content is not well-formed XML: " + e.detail());
        }
    }

    private static Element root(String content, String name) {
        List<Element> roots = roots(content);
        if (roots.size() != 1 || !Dom.name(roots.get(0)).equals(name)) {
            throw contentInvalid("content must be one <" + name + ">");
        }
        return roots.get(0);
    }
}
