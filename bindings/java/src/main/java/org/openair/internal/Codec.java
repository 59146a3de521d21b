package org.openair.internal;

import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.HashSet;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Locale;
import java.util.Map;
import java.util.Set;
import java.util.regex.Pattern;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.Reference;
import org.openair.RemoteProtocolException;
import org.openair.Slot;
import org.w3c.dom.DOMException;
import org.w3c.dom.Document;
import org.w3c.dom.Element;
import org.w3c.dom.Node;

/**
 * Message to and from XML (spec 3, 4): the lenient reader and the canonical writer.
 *
 * <p>Reading accepts every legacy spelling (OA-MSG-3: names in any case, {@code ms} for
 * {@code msec}, slots in any order), keeps unknown slots in order (OA-MSG-5) and answers bad input
 * with XML_MALFORMED / XML_FORBIDDEN / XML_TOO_DEEP ({@link SafeXml}) or MESSAGE_INVALID. Writing
 * builds a DOM in the canonical form of spec 3.5 and serializes it with {@link XmlWriter}; XML held
 * as text (XML content, history, XML slots) is parsed and grafted into the tree, never
 * concatenated.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class Codec {
    private static final Pattern DIGITS = Pattern.compile("[0-9]+");
    private static final Pattern DECIMAL =
            Pattern.compile("[+-]?(?:[0-9]+(?:\\.[0-9]*)?|\\.[0-9]+)");
    private static final Set<String> TEXT_SLOTS = Set.of(
            "type", "id", "from", "to", "cc", "stored", "isresponse", "comment", "netprotocol");
    private static final Set<String> READ_SLOTS =
            Set.of("inreplyto", "postedtime", "receivedtime", "history", "wbid", "content");
    private static final Set<String> DERIVED_SLOTS = Set.of("binarysizes", "totalbinarysize");
    private static final Set<String> LISTED_EXTRAS = Set.of("extensions");

    private Codec() {}

    // ---------------------------------------------------------------------------- decoding

    /**
     * Parse the XML of a Message or Receive frame into a message carrying {@code chunks}, which
     * it adopts (not copied: pass arrays nobody else holds or changes).
     *
     * @param xml the XML bytes
     * @param chunks the binary chunks that followed it
     * @param maxBytes the XML size limit
     * @param maxDepth the depth limit
     * @return the message
     * @throws RemoteProtocolException XML_MALFORMED (also for a root other than message,
     *     OA-MSG-1), XML_FORBIDDEN, XML_TOO_DEEP or MESSAGE_INVALID
     */
    public static Message decode(byte[] xml, List<byte[]> chunks, long maxBytes, int maxDepth) {
        return decode(xml, chunks, maxBytes, maxDepth, false);
    }

    /**
     * Parse like {@link #decode(byte[], List, long, int)}, optionally reading a priority outside
     * 0.0-6.999 as the nearest end of the range instead of refusing it: what a client does with
     * the deliveries and replies it receives (OA-MSG-19; Psyclone echoes 6.999 as 7.00).
     *
     * @param xml the XML bytes
     * @param chunks the binary chunks that followed it
     * @param maxBytes the XML size limit
     * @param maxDepth the depth limit
     * @param clampPriority clamp an out-of-range priority (a client) or refuse it (a server
     *     reading a post, OA-MSG-6)
     * @return the message
     */
    public static Message decode(byte[] xml, List<byte[]> chunks, long maxBytes, int maxDepth,
            boolean clampPriority) {
        Element root = SafeXml.parse(xml, maxBytes, maxDepth);
        if (!Dom.name(root).equals("message")) { // OA-MSG-1
            throw SafeXml.malformed("root element is <" + root.getTagName() + ">, not <message>");
        }
        return decodeElement(root, chunks, clampPriority);
    }

    /**
     * Decode with the default limits.
     *
     * @param xml the XML bytes
     * @return the message
     */
    public static Message decode(byte[] xml) {
        return decode(xml, List.of(), SafeXml.DEFAULT_MAX_BYTES, SafeXml.DEFAULT_MAX_DEPTH);
    }

    /**
     * Read a {@code <message>} element (any case), e.g. a stored copy inside a content object.
     * A stored copy is what a server wrote, so a priority outside 0.0-6.999 is clamped
     * (OA-MSG-19).
     *
     * @param el the element
     * @return the message
     */
    public static Message fromElement(Element el) {
        return fromElement(el, List.of());
    }

    /**
     * Read a nested {@code <message>} element with the attachments it lists (OA-MSG-21).
     *
     * @param el the element
     * @param chunks its binary chunks
     * @return the message
     */
    public static Message fromElement(Element el, List<byte[]> chunks) {
        if (!Dom.name(el).equals("message")) {
            throw invalid("expected a <message> element, found <" + el.getTagName() + ">");
        }
        return decodeElement(el, chunks, true);
    }

    static RemoteProtocolException invalid(String detail) {
        return new RemoteProtocolException(ErrorCode.MESSAGE_INVALID, detail);
    }

    private static Message decodeElement(Element root, List<byte[]> chunks,
            boolean clampPriority) {
        Message.Builder b = Message.builder("").id("");
        readRootAttributes(root, b, clampPriority);
        List<Slot> extras = new ArrayList<>();
        Set<String> seen = new HashSet<>();
        String type = null;
        for (Node n = root.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.TEXT_NODE) {
                noText(n.getNodeValue(), "message");
                continue;
            }
            if (n.getNodeType() != Node.ELEMENT_NODE) {
                continue; // a comment or processing instruction
            }
            Element child = (Element) n;
            String name = Dom.name(child);
            if (TEXT_SLOTS.contains(name) || READ_SLOTS.contains(name)
                    || DERIVED_SLOTS.contains(name) || LISTED_EXTRAS.contains(name)) {
                if (!seen.add(name)) { // OA-MSG-16
                    throw invalid("slot <" + child.getTagName() + "> occurs more than once");
                }
            }
            if (name.equals("type")) {
                type = text(child);
            } else if (TEXT_SLOTS.contains(name)) {
                setText(b, name, text(child));
            } else if (READ_SLOTS.contains(name)) {
                readSlot(b, name, child);
            } else if (!DERIVED_SLOTS.contains(name)) {
                extras.add(readExtra(child)); // OA-MSG-5
            }
        }
        if (type == null || type.isEmpty()) { // OA-MSG-2
            throw invalid("the type slot is missing or empty");
        }
        // The chunks come fresh from the frame reader (or a copy): adopted, not copied again.
        return Chunks.adopt(b.type(type).extras(extras), chunks);
    }

    private static void setText(Message.Builder b, String name, String value) {
        switch (name) {
            case "id" -> b.id(value);
            case "from" -> b.sender(value);
            case "to" -> b.to(value);
            case "cc" -> b.cc(value);
            case "stored" -> b.stored(value);
            case "isresponse" -> b.isresponse(value);
            case "comment" -> b.comment(value);
            default -> b.netprotocol(value);
        }
    }

    private static void readSlot(Message.Builder b, String name, Element el) {
        switch (name) {
            case "inreplyto" -> b.inreplyto(readInReplyTo(el));
            case "postedtime" -> b.posted(TimeXml.timeFromElement(el));
            case "receivedtime" -> b.received(TimeXml.timeFromElement(el));
            case "history" -> b.history(innerElements(el, "history"));
            case "wbid" -> b.wbid(readWbid(el));
            default -> readContent(el, b);
        }
    }

    private static void noText(String text, String where) {
        if (!Dom.isBlank(text)) {
            throw invalid("text '" + clip(text) + "' between the elements of <" + where + ">");
        }
    }

    static String clip(String text) {
        String t = Dom.strip(text);
        return t.length() <= 40 ? t : t.substring(0, 40) + "...";
    }

    /** Read attributes keyed by folded name; the same name in two spellings is invalid. */
    static Map<String, String> attributes(Element el) {
        Map<String, String> out = new LinkedHashMap<>();
        for (String name : Dom.attributeOrder(el)) {
            if (out.put(Dom.fold(name), el.getAttribute(name)) != null) { // OA-MSG-3
                throw invalid("attribute '" + Dom.fold(name) + "' given twice on <"
                        + el.getTagName() + ">");
            }
        }
        return out;
    }

    private static void readRootAttributes(Element root, Message.Builder b,
            boolean clampPriority) {
        Map<String, String> attrs = attributes(root);
        String priority = attrs.get("priority");
        if (priority != null) {
            double value = decimal(priority, "priority");
            if (!(value >= 0.0 && value <= 6.999)) {
                if (!clampPriority) { // OA-MSG-6: a server refuses a post out of range
                    throw invalid("priority '" + priority + "' is outside 0.0-6.999");
                }
                value = value < 0.0 ? 0.0 : 6.999; // OA-MSG-19: a legacy peer's 7.00 is 6.999
            }
            b.priority(value);
        }
        String ttl = attrs.get("timetolive");
        if (ttl != null) {
            b.timetolive(decimal(ttl, "timetolive"));
        }
        String noreply = attrs.get("noreply");
        if (noreply != null) {
            String v = Dom.strip(noreply).toLowerCase(Locale.ROOT);
            if (!v.equals("yes") && !v.equals("no")) { // OA-MSG-15
                throw invalid("noreply must be yes or no, got '" + noreply + "'");
            }
            b.noreply(v.equals("yes"));
        }
    }

    private static double decimal(String text, String what) {
        String s = Dom.strip(text);
        if (!DECIMAL.matcher(s).matches()) {
            throw invalid(what + " is not a decimal number: '" + text + "'");
        }
        return Double.parseDouble(s) + 0.0; // + 0.0 turns -0.0 into 0.0
    }

    /** The text of a text slot: comments are skipped, elements are invalid (OA-MSG-9). */
    static String text(Element el) {
        StringBuilder sb = new StringBuilder();
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.TEXT_NODE) {
                sb.append(n.getNodeValue());
            } else if (n.getNodeType() == Node.ELEMENT_NODE) {
                throw invalid("slot <" + el.getTagName() + "> must be text, found <"
                        + ((Element) n).getTagName() + ">");
            }
        }
        return sb.toString();
    }

    /** Serialize the child elements of {@code el}; only white space may sit between them. */
    private static String innerElements(Element el, String where) {
        StringBuilder sb = new StringBuilder();
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.ELEMENT_NODE) {
                XmlWriter.write(n, sb);
            } else if (n.getNodeType() == Node.TEXT_NODE) {
                noText(n.getNodeValue(), where);
            }
        }
        return sb.toString();
    }

    /** Serialize the inside of XML content or an unknown slot: elements and non-blank text. */
    static String innerMixed(Element el) {
        StringBuilder sb = new StringBuilder();
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.ELEMENT_NODE) {
                XmlWriter.write(n, sb);
            } else if (n.getNodeType() == Node.TEXT_NODE && !Dom.isBlank(n.getNodeValue())) {
                XmlWriter.text(n.getNodeValue(), sb);
            }
        }
        return sb.toString();
    }

    private static Slot readExtra(Element el) {
        String name = el.getTagName();
        int colon = name.indexOf(':');
        name = colon >= 0 ? name.substring(colon + 1) : name;
        if (Dom.hasElements(el)) {
            return new Slot(name, innerMixed(el), true);
        }
        return new Slot(name, text(el), false);
    }

    private static void readContent(Element el, Message.Builder b) {
        String language = attributes(el).getOrDefault("language", "");
        if (language.toLowerCase(Locale.ROOT).equals("xml")) { // OA-MSG-10
            // Stray text is kept: the command that reads the content judges it (OA-MSG-18).
            b.language(language).xmlContent(innerMixed(el)).language(language);
        } else {
            b.language(language).content(text(el)).language(language);
        }
    }

    private static long readWbid(Element el) {
        String s = Dom.strip(text(el));
        if (!DIGITS.matcher(s).matches()) { // OA-MSG-13
            throw invalid("wbid must be a non-negative integer, got '" + clip(s) + "'");
        }
        try {
            return Long.parseLong(s);
        } catch (NumberFormatException e) {
            throw invalid("wbid does not fit 63 bits: '" + clip(s) + "'");
        }
    }

    private static Reference readInReplyTo(Element el) {
        List<Element> refs = new ArrayList<>();
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.TEXT_NODE) {
                noText(n.getNodeValue(), "inreplyto");
            } else if (n.getNodeType() == Node.ELEMENT_NODE) {
                Element child = (Element) n;
                if (!Dom.name(child).equals("reference")) {
                    throw invalid("inreplyto holds <" + child.getTagName() + ">, not <reference>");
                }
                refs.add(child);
            }
        }
        if (refs.size() != 1) { // OA-MSG-11
            throw invalid("inreplyto must hold one reference, found " + refs.size());
        }
        return reference(refs.get(0));
    }

    private static Reference reference(Element el) {
        Map<String, String> attrs = attributes(el);
        AirTime time = null;
        if (attrs.containsKey("sec") || attrs.containsKey("msec") || attrs.containsKey("ms")) {
            time = TimeXml.timeFromAttributes(attrs, "reference");
        } else {
            for (Element child : Dom.children(el)) { // Psyclone writes a postedTime child
                if (Dom.name(child).equals("postedtime")) {
                    time = TimeXml.timeFromElement(child);
                }
            }
        }
        return new Reference(attrs.get("id"), attrs.get("type"), attrs.get("from"),
                attrs.get("to"), attrs.get("cc"), attrs.get("stored"), time);
    }

    // ---------------------------------------------------------------------------- encoding

    /**
     * Write {@code msg} in canonical form (spec 3.5): UTF-8 bytes, no XML declaration.
     *
     * @param msg the message
     * @return the XML bytes
     * @throws ApiMisuseException for a message that cannot be written: an empty type, a character
     *     XML 1.0 forbids (OA-MSG-14), XML content that is not well-formed, an unknown slot whose
     *     name is not an XML name or shadows a known slot
     */
    public static byte[] encode(Message msg) {
        return encode(msg, null);
    }

    /**
     * Write {@code msg} in canonical form with {@code binarysizes} and {@code totalbinarysize}
     * for chunks that are sent separately (OA-FRAME-4).
     *
     * @param msg the message (its own chunks are ignored when {@code chunkSizes} is given)
     * @param chunkSizes the sizes of the chunks that follow, or null for the message's own
     * @return the XML bytes
     */
    public static byte[] encode(Message msg, long[] chunkSizes) {
        long[] sizes = chunkSizes != null ? chunkSizes : sizes(msg);
        String fast = FastWriter.write(msg, sizes);
        if (fast != null) {
            return fast.getBytes(StandardCharsets.UTF_8);
        }
        return encodeDom(msg, sizes);
    }

    /**
     * Write {@code msg} through the DOM (the general path; {@link FastWriter} writes the same
     * bytes for the messages it takes).
     *
     * @param msg the message
     * @param sizes the sizes of its chunks
     * @return the XML bytes
     */
    static byte[] encodeDom(Message msg, long[] sizes) {
        return XmlWriter.write(toElement(msg, SafeXml.newDocument(), sizes))
                .getBytes(StandardCharsets.UTF_8);
    }

    /** @return true when {@code name} is the name of a slot this codec knows (any case) */
    static boolean isKnownSlot(String name) {
        return KNOWN.contains(Dom.fold(name));
    }

    static long[] chunkSizes(Message msg) {
        return sizes(msg);
    }

    private static long[] sizes(Message msg) {
        long[] sizes = new long[msg.binaryCount()];
        for (int i = 0; i < sizes.length; i++) {
            sizes[i] = msg.binaryView(i).remaining(); // no copy of the chunk
        }
        return sizes;
    }

    /**
     * Build the canonical {@code <message>} element for {@code msg} in {@code doc}.
     *
     * @param msg the message
     * @param doc the document that owns the element
     * @return the element
     */
    public static Element toElement(Message msg, Document doc) {
        return toElement(msg, doc, sizes(msg));
    }

    private static Element toElement(Message msg, Document doc, long[] chunkSizes) {
        if (msg.type().isEmpty()) { // OA-MSG-2
            throw new ApiMisuseException("a message needs a non-empty type");
        }
        Element root = doc.createElement("message");
        if (msg.priority() != null) {
            SafeXml.setAttr(root, "priority", TimeXml.formatDecimal(msg.priority(), "priority"));
        }
        if (msg.timetolive() != null) {
            SafeXml.setAttr(root, "timetolive", TimeXml.formatDecimal(msg.timetolive(), "timetolive"));
        }
        if (msg.noreply()) {
            SafeXml.setAttr(root, "noreply", "yes"); // OA-MSG-15
        }
        textChild(root, "type", msg.type());
        textChild(root, "id", msg.id());
        textChild(root, "from", msg.sender());
        textChild(root, "to", msg.to());
        textChild(root, "cc", msg.cc());
        textChild(root, "stored", msg.stored());
        textChild(root, "isresponse", msg.isresponse());
        middle(root, msg, chunkSizes);
        root.appendChild(content(msg, doc));
        for (Slot slot : msg.extras()) {
            root.appendChild(extra(slot, doc));
        }
        return root;
    }

    private static void middle(Element root, Message msg, long[] chunkSizes) {
        Document doc = root.getOwnerDocument();
        if (msg.inreplyto() != null) {
            Element irt = doc.createElement("inreplyto");
            irt.appendChild(referenceElement(msg.inreplyto(), doc));
            root.appendChild(irt);
        }
        if (msg.posted() != null) { // a message received without one cannot be given one here
            root.appendChild(TimeXml.timeElement("postedTime", msg.posted(), doc));
        }
        if (msg.received() != null) {
            root.appendChild(TimeXml.timeElement("receivedTime", msg.received(), doc));
        }
        if (!msg.comment().isEmpty()) {
            textChild(root, "comment", msg.comment());
        }
        if (!msg.history().isEmpty()) {
            Element history = doc.createElement("history");
            graft(history, msg.history(), "history");
            root.appendChild(history);
        }
        if (msg.wbid() != null) {
            textChild(root, "wbid", String.format("%08d", msg.wbid())); // OA-MSG-13
        }
        if (!msg.netprotocol().isEmpty()) {
            textChild(root, "netprotocol", msg.netprotocol());
        }
        if (chunkSizes.length > 0) { // OA-FRAME-4
            StringBuilder sizes = new StringBuilder();
            long total = 0;
            for (long size : chunkSizes) {
                sizes.append(sizes.length() == 0 ? "" : ",").append(size);
                total += size;
            }
            textChild(root, "binarysizes", sizes.toString());
            textChild(root, "totalbinarysize", Long.toString(total));
        }
    }

    private static void textChild(Element parent, String name, String text) {
        Element el = parent.getOwnerDocument().createElement(name);
        if (!text.isEmpty()) { // an empty slot is written <cc/>
            el.appendChild(parent.getOwnerDocument().createTextNode(text));
        }
        parent.appendChild(el);
    }

    private static Element referenceElement(Reference ref, Document doc) {
        Element el = doc.createElement("reference");
        SafeXml.setAttr(el, "id", ref.id());
        String[][] optional = {{"type", ref.type()}, {"from", ref.sender()}, {"to", ref.to()},
            {"cc", ref.cc()}, {"stored", ref.stored()}};
        for (String[] pair : optional) {
            if (!pair[1].isEmpty()) {
                SafeXml.setAttr(el, pair[0], pair[1]);
            }
        }
        if (ref.time() != null) { // schemas/message.xsd ReferenceType has no usec
            SafeXml.setAttr(el, "sec", Long.toString(ref.time().sec()));
            SafeXml.setAttr(el, "msec", Integer.toString(ref.time().msec()));
        }
        return el;
    }

    private static Element content(Message msg, Document doc) {
        Element el = doc.createElement("content");
        boolean xmlLanguage = msg.language().toLowerCase(Locale.ROOT).equals("xml");
        if (msg.contentIsXml()) { // OA-MSG-10: written unescaped, parsed first
            SafeXml.setAttr(el, "language", xmlLanguage ? msg.language() : "xml");
            if (!msg.content().isEmpty()) {
                graft(el, msg.content(), "content");
            }
            return el;
        }
        if (xmlLanguage) {
            throw new ApiMisuseException(
                    "text content cannot be labelled language='" + msg.language() + "'");
        }
        SafeXml.setAttr(el, "language", msg.language());
        if (!msg.content().isEmpty()) {
            el.appendChild(doc.createTextNode(msg.content()));
        }
        return el;
    }

    private static final Set<String> KNOWN = known();

    private static Set<String> known() {
        Set<String> s = new HashSet<>(TEXT_SLOTS);
        s.addAll(READ_SLOTS);
        s.addAll(DERIVED_SLOTS);
        return Set.copyOf(s);
    }

    private static Element extra(Slot slot, Document doc) {
        if (KNOWN.contains(Dom.fold(slot.name()))) {
            throw new ApiMisuseException("extension slot '" + slot.name()
                    + "' has the name of a known slot");
        }
        Element el;
        try {
            el = doc.createElement(slot.name());
        } catch (DOMException e) {
            throw new ApiMisuseException("extension slot name '" + slot.name()
                    + "' is not an XML name");
        }
        if (slot.xml()) {
            graft(el, slot.value(), "extension slot '" + slot.name() + "'");
        } else if (!slot.value().isEmpty()) {
            el.appendChild(doc.createTextNode(slot.value()));
        }
        return el;
    }

    /** Copy inner XML (elements and text) into {@code el}, parsed by the hardened parser. */
    private static void graft(Element el, String xml, String where) {
        if (XmlWriter.firstInvalid(xml) >= 0) {
            XmlWriter.checked(xml); // OA-MSG-14: named precisely
        }
        Element wrapper;
        try {
            wrapper = SafeXml.parseWrapped(xml, SafeXml.DEFAULT_MAX_DEPTH);
        } catch (OpenAirException e) { // the caller's string, not the peer's
            throw new ApiMisuseException(where + " is not well-formed inner XML: " + e.detail());
        }
        Document doc = el.getOwnerDocument();
        for (Node n = wrapper.getFirstChild(); n != null; n = n.getNextSibling()) {
            el.appendChild(importWithOrder(n, doc));
        }
    }

    /** Import a node into {@code doc}, keeping the recorded attribute order of its elements. */
    static Node importWithOrder(Node n, Document doc) {
        if (n.getNodeType() != Node.ELEMENT_NODE) {
            return doc.importNode(n, false);
        }
        Element src = (Element) n;
        Element copy = doc.createElement(src.getTagName());
        for (String name : Dom.attributeOrder(src)) {
            SafeXml.setAttr(copy, name, src.getAttribute(name));
        }
        for (Node c = src.getFirstChild(); c != null; c = c.getNextSibling()) {
            copy.appendChild(importWithOrder(c, doc));
        }
        return copy;
    }
}
