package org.openair.internal;

import java.util.concurrent.ConcurrentHashMap;
import java.util.regex.Pattern;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.Slot;
import org.w3c.dom.Element;
import org.w3c.dom.Node;

/**
 * Writes the canonical form of spec 3.5 straight into a {@link StringBuilder}, for the messages a
 * client sends most: no {@code inreplyto}, no {@code history}, extension slots of text with plain
 * names. XML content is parsed once by the hardened parser and its canonical text remembered
 * (one entry per thread), so a writer that repeats a content ({@code <datasample/>}, a
 * registration) does not parse it again. Anything else returns null and goes through the DOM
 * path of {@link Codec}, which writes the same bytes (CodecTest checks both on every vector).
 *
 * <p>Threading: stateless apart from the per-thread memo and a bounded shared cache of decimals;
 * thread-safe.
 */
final class FastWriter {
    private static final Pattern PLAIN_NAME = Pattern.compile("[A-Za-z_][A-Za-z0-9_.-]*");
    private static final ThreadLocal<String[]> LAST_CONTENT = ThreadLocal.withInitial(
            () -> new String[2]);
    private static final ConcurrentHashMap<Double, String> DECIMALS = new ConcurrentHashMap<>();

    private FastWriter() {}

    /**
     * Write {@code msg}, or return null when the DOM path must.
     *
     * @param msg the message
     * @param chunkSizes the sizes of the chunks that follow
     * @return the XML text, or null
     */
    static String write(Message msg, long[] chunkSizes) {
        if (msg.inreplyto() != null || !msg.history().isEmpty()) {
            return null;
        }
        for (Slot slot : msg.extras()) {
            if (slot.xml() || !PLAIN_NAME.matcher(slot.name()).matches()
                    || Codec.isKnownSlot(slot.name())) {
                return null;
            }
        }
        if (msg.type().isEmpty()) { // OA-MSG-2
            throw new ApiMisuseException("a message needs a non-empty type");
        }
        StringBuilder sb = new StringBuilder(256 + msg.content().length());
        sb.append("<message");
        if (msg.priority() != null) {
            attr(sb, "priority", decimal(msg.priority(), "priority"));
        }
        if (msg.timetolive() != null) {
            attr(sb, "timetolive", decimal(msg.timetolive(), "timetolive"));
        }
        if (msg.noreply()) {
            attr(sb, "noreply", "yes"); // OA-MSG-15
        }
        sb.append('>');
        text(sb, "type", msg.type());
        text(sb, "id", msg.id());
        text(sb, "from", msg.sender());
        text(sb, "to", msg.to());
        text(sb, "cc", msg.cc());
        text(sb, "stored", msg.stored());
        text(sb, "isresponse", msg.isresponse());
        time(sb, "postedTime", msg.posted());
        time(sb, "receivedTime", msg.received());
        if (!msg.comment().isEmpty()) {
            text(sb, "comment", msg.comment());
        }
        if (msg.wbid() != null) {
            text(sb, "wbid", String.format("%08d", msg.wbid())); // OA-MSG-13
        }
        if (!msg.netprotocol().isEmpty()) {
            text(sb, "netprotocol", msg.netprotocol());
        }
        if (chunkSizes.length > 0) { // OA-FRAME-4
            StringBuilder sizes = new StringBuilder();
            long total = 0;
            for (long size : chunkSizes) {
                sizes.append(sizes.length() == 0 ? "" : ",").append(size);
                total += size;
            }
            text(sb, "binarysizes", sizes.toString());
            text(sb, "totalbinarysize", Long.toString(total));
        }
        content(sb, msg);
        for (Slot slot : msg.extras()) {
            text(sb, slot.name(), slot.value());
        }
        return sb.append("</message>").toString();
    }

    private static String decimal(double value, String what) {
        String s = DECIMALS.get(value);
        if (s == null) {
            s = TimeXml.formatDecimal(value, what);
            if (DECIMALS.size() < 1024) {
                DECIMALS.put(value, s);
            }
        }
        return s;
    }

    private static void attr(StringBuilder sb, String name, String value) {
        sb.append(' ').append(name).append("=\"");
        XmlWriter.attrValue(value, sb);
        sb.append('"');
    }

    private static void text(StringBuilder sb, String name, String value) {
        sb.append('<').append(name);
        if (value.isEmpty()) { // an empty slot is written <cc/>
            sb.append("/>");
            return;
        }
        sb.append('>');
        XmlWriter.text(value, sb);
        sb.append("</").append(name).append('>');
    }

    private static void time(StringBuilder sb, String name, AirTime t) {
        if (t == null) {
            return;
        }
        sb.append('<').append(name).append(" sec=\"").append(t.sec()).append("\" msec=\"")
                .append(t.msec()).append('"');
        if (t.usec() != null) {
            sb.append(" usec=\"").append(t.usec().intValue()).append('"');
        }
        sb.append("/>");
    }

    private static void content(StringBuilder sb, Message msg) {
        boolean xmlLanguage = msg.language().equalsIgnoreCase("xml");
        sb.append("<content");
        if (msg.contentIsXml()) { // OA-MSG-10: written unescaped, parsed first
            attr(sb, "language", xmlLanguage ? msg.language() : "xml");
            String inner = canonicalXml(msg.content());
            if (inner.isEmpty()) {
                sb.append("/>");
            } else {
                sb.append('>').append(inner).append("</content>");
            }
            return;
        }
        if (xmlLanguage) {
            throw new ApiMisuseException(
                    "text content cannot be labelled language='" + msg.language() + "'");
        }
        attr(sb, "language", msg.language());
        if (msg.content().isEmpty()) {
            sb.append("/>");
            return;
        }
        sb.append('>');
        XmlWriter.text(msg.content(), sb);
        sb.append("</content>");
    }

    /** The canonical text of inner XML: parsed by the hardened parser, remembered per thread. */
    private static String canonicalXml(String xml) {
        if (xml.isEmpty()) {
            return "";
        }
        String[] memo = LAST_CONTENT.get();
        if (xml.equals(memo[0])) {
            return memo[1];
        }
        if (XmlWriter.firstInvalid(xml) >= 0) {
            XmlWriter.checked(xml); // OA-MSG-14: named precisely
        }
        Element wrapper;
        try {
            wrapper = SafeXml.parseWrapped(xml, SafeXml.DEFAULT_MAX_DEPTH);
        } catch (OpenAirException e) { // the caller's string, not the peer's
            throw new ApiMisuseException("content is not well-formed inner XML: " + e.detail());
        }
        StringBuilder sb = new StringBuilder(xml.length());
        for (Node n = wrapper.getFirstChild(); n != null; n = n.getNextSibling()) {
            XmlWriter.write(n, sb);
        }
        String out = sb.toString();
        memo[0] = xml;
        memo[1] = out;
        return out;
    }
}
