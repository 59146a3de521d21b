package org.openair.internal;

import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.regex.Pattern;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.Capabilities;
import org.openair.DeliveryPath;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.OpenAirException;
import org.openair.Registration;
import org.openair.RemoteProtocolException;
import org.openair.RetrieveSpec;
import org.openair.Trigger;
import org.openair.Wakeup;
import org.w3c.dom.Document;
import org.w3c.dom.Element;

/**
 * The content objects a client reads and writes (spec 3.4, 8, 9, 15): capabilities, retrieve
 * results, wakeups, registrations and retrieve specifications. Everything is built as DOM and
 * serialized with {@link XmlWriter}.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class ContentObjects {
    /** The type of a wakeup (spec 8.7). */
    public static final String WAKEUP_TYPE = "AIR.Instruct.Wakeup";

    private static final Pattern UINT = Pattern.compile("\\s*\\+?[0-9]{1,18}\\s*");

    private ContentObjects() {}

    private static RemoteProtocolException contentInvalid(String detail) {
        return new RemoteProtocolException(ErrorCode.CONTENT_INVALID, detail);
    }

    /** Parse XML content into its top-level elements; malformed content is CONTENT_INVALID. */
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
            throw contentInvalid("content must be one <" + name + ">, found " + names(roots));
        }
        return roots.get(0);
    }

    private static String names(List<Element> els) {
        if (els.isEmpty()) {
            return "no element";
        }
        List<String> out = new ArrayList<>();
        for (Element el : els) {
            out.add("<" + Dom.name(el) + ">");
        }
        return String.join(", ", out);
    }

    /**
     * Read a {@code <capabilities protocol server>} (OA-CAP-1); unknown children are ignored
     * (OA-CAP-3), a repeated extension or limit keeps its first occurrence.
     *
     * @param content the CAPABILITIES reply's content
     * @return the capabilities
     * @throws RemoteProtocolException CONTENT_INVALID
     */
    public static Capabilities parseCapabilities(String content) {
        Element root = root(content, "capabilities");
        String protocol = Dom.attr(root, "protocol");
        String server = Dom.attr(root, "server");
        if (protocol == null || protocol.isEmpty()) {
            throw contentInvalid("capabilities without a protocol"); // OA-CAP-1
        }
        if (server == null) {
            throw contentInvalid("capabilities without a server"); // OA-CAP-1
        }
        List<String> extensions = new ArrayList<>();
        Map<String, Long> limits = new LinkedHashMap<>();
        for (Element child : Dom.children(root)) {
            String kind = Dom.name(child);
            if (!kind.equals("extension") && !kind.equals("limit")) {
                continue; // OA-CAP-3: what a client does not know, it ignores
            }
            String name = Dom.attr(child, "name");
            if (name == null || name.isEmpty()) {
                throw contentInvalid("<" + kind + "> without a name");
            }
            if (kind.equals("extension")) {
                if (!extensions.contains(name)) {
                    extensions.add(name);
                }
                continue;
            }
            String value = Dom.attr(child, "value");
            if (value == null || !UINT.matcher(value).matches()) {
                throw contentInvalid("limit '" + name + "' has no non-negative integer value");
            }
            limits.putIfAbsent(name, Long.parseLong(Dom.strip(value).replace("+", "")));
        }
        return new Capabilities(protocol, server, extensions, limits);
    }

    /**
     * Read the messages of {@code <objectcollection><object><message>…} (OA-RET-7).
     *
     * @param content the content ("" reads as no message)
     * @return the messages, in order
     * @throws RemoteProtocolException CONTENT_INVALID
     */
    public static List<Message> parseMessageCollection(String content) {
        if (Dom.isBlank(content)) {
            return List.of();
        }
        return readCollection(root(content, "objectcollection"), new Attachments(List.of()));
    }

    /**
     * Read a retrieve reply's results, each with the attachments it lists (OA-RET-19,
     * OA-MSG-21).
     *
     * @param reply the reply
     * @return the messages, in order
     * @throws RemoteProtocolException CONTENT_INVALID, also when the chunks do not match
     */
    public static List<Message> parseMessageCollection(Message reply) {
        Attachments chunks = new Attachments(reply.binary());
        List<Message> out = Dom.isBlank(reply.content()) ? List.of()
                : readCollection(root(reply.content(), "objectcollection"), chunks);
        chunks.finish();
        return out;
    }

    /**
     * The chunks of an outer message handed to its nested stored copies in document order,
     * each taking as many as its own {@code binarysizes} lists, of those sizes (OA-MSG-21).
     */
    private static final class Attachments {
        private final List<byte[]> chunks;
        private int next;

        Attachments(List<byte[]> chunks) {
            this.chunks = chunks;
        }

        List<byte[]> take(Element message) {
            List<byte[]> out = new ArrayList<>();
            for (Element slot : Dom.children(message)) {
                if (!Dom.name(slot).equals("binarysizes") || Dom.isBlank(Dom.innerText(slot))) {
                    continue;
                }
                for (String part : Dom.strip(Dom.innerText(slot)).split(",", -1)) {
                    if (!UINT.matcher(part).matches()) {
                        throw contentInvalid("nested binarysizes '" + part + "' is not a size");
                    }
                    long size = Long.parseLong(Dom.strip(part).replace("+", ""));
                    if (next >= chunks.size() || chunks.get(next).length != size) {
                        throw contentInvalid("the frame's chunks do not match the nested"
                                + " messages' binarysizes (OA-MSG-21)");
                    }
                    out.add(chunks.get(next++));
                }
                break;
            }
            return out;
        }

        void finish() {
            if (next != chunks.size()) {
                throw contentInvalid("the frame carries " + chunks.size() + " chunk(s), the nested"
                        + " messages list " + next + " (OA-MSG-21)");
            }
        }
    }

    private static List<Message> readCollection(Element root, Attachments chunks) {
        if (!Dom.name(root).equals("objectcollection")) {
            throw contentInvalid("expected <objectcollection>, found <" + Dom.name(root) + ">");
        }
        List<Message> out = new ArrayList<>();
        int index = 0;
        for (Element obj : Dom.children(root)) {
            if (!Dom.name(obj).equals("object")) {
                throw contentInvalid("<objectcollection> holds <" + Dom.name(obj) + ">");
            }
            Element inner = single(obj, "object " + index);
            if (!Dom.name(inner).equals("message")) {
                throw contentInvalid("object " + index + " holds <" + Dom.name(inner) + ">");
            }
            out.add(message(inner, "object " + index, chunks));
            index++;
        }
        return out;
    }

    private static Message message(Element el, String where, Attachments chunks) {
        try {
            return Codec.fromElement(el, chunks.take(el));
        } catch (RemoteProtocolException e) {
            throw contentInvalid(where + ": " + e.detail());
        }
    }

    private static Element single(Element parent, String where) {
        List<Element> kids = Dom.children(parent);
        if (kids.size() != 1) {
            throw contentInvalid(where + " must hold one element, found " + kids.size());
        }
        return kids.get(0);
    }

    /**
     * Take an {@code AIR.Instruct.Wakeup} apart (spec 8.7, 8.8). A missing TriggerMessage is a
     * phase update (OA-WAKE-8); empty content is a phase update without a phase.
     *
     * @param msg the wakeup message
     * @param receivedNanos when it arrived
     * @param path the connection that carried it
     * @return the wakeup
     * @throws RemoteProtocolException CONTENT_INVALID for content that is not a wakeup's
     */
    public static Wakeup parseWakeup(Message msg, long receivedNanos, DeliveryPath path) {
        if (!msg.type().equals(WAKEUP_TYPE)) {
            throw contentInvalid("'" + msg.type() + "' is not " + WAKEUP_TYPE);
        }
        List<Element> roots = roots(msg.content());
        if (roots.isEmpty()) {
            return new Wakeup(msg, null, List.of(), "", "", receivedNanos, path);
        }
        if (roots.size() != 1 || !Dom.name(roots.get(0)).equals("objectdictionary")) {
            throw contentInvalid("wakeup content must be one <objectdictionary>, found "
                    + names(roots));
        }
        Map<String, Element> objects = objects(roots.get(0));
        Element trigger = objects.get("TriggerMessage");
        Element retrieved = objects.get("RetrievedMessages");
        Attachments chunks = new Attachments(msg.binary()); // OA-WAKE-10: trigger first
        Element phase = objects.get("PhaseSpec");
        if (trigger != null && !Dom.name(trigger).equals("message")) {
            throw contentInvalid("TriggerMessage holds <" + Dom.name(trigger) + ">");
        }
        if (phase != null && !Dom.name(phase).equals("phase")) {
            throw contentInvalid("PhaseSpec holds <" + Dom.name(phase) + ">, not a phase");
        }
        Message triggerMessage = trigger == null ? null
                : message(trigger, "TriggerMessage", chunks);
        List<Message> retrievedMessages = retrieved == null ? List.of()
                : readCollection(retrieved, chunks);
        chunks.finish();
        return new Wakeup(msg, triggerMessage, retrievedMessages,
                phase == null ? "" : orEmpty(Dom.attr(phase, "lasttrigger")),
                phase == null ? "" : phaseName(phase),
                receivedNanos, path);
    }

    private static String phaseName(Element phase) {
        String name = Dom.attr(phase, "name");
        return name != null ? name : orEmpty(Dom.attr(phase, "id"));
    }

    private static String orEmpty(String s) {
        return s == null ? "" : s;
    }

    /** The objects of an objectdictionary by name; an empty object maps to null. */
    private static Map<String, Element> objects(Element root) {
        Map<String, Element> found = new LinkedHashMap<>();
        for (Element obj : Dom.children(root)) {
            if (!Dom.name(obj).equals("object")) {
                throw contentInvalid("<objectdictionary> holds <" + Dom.name(obj) + ">");
            }
            String name = Dom.attr(obj, "name");
            if (name == null) {
                throw contentInvalid("wakeup object without a name");
            }
            if (found.containsKey(name)) {
                throw contentInvalid("wakeup object '" + name + "' appears twice");
            }
            found.put(name, Dom.hasElements(obj) ? single(obj, name) : null);
        }
        return found;
    }

    // ------------------------------------------------------------------------------ writing

    /**
     * Write {@code <tcplocation port="N"/>}: the content of a BIND that asks for a port
     * (OA-SESS-4).
     *
     * @param port the port
     * @return the content
     */
    public static String encodePortRequest(int port) {
        Element el = SafeXml.newDocument().createElement("tcplocation");
        SafeXml.setAttr(el, "port", Integer.toString(port));
        return XmlWriter.write(el);
    }

    /**
     * Write AIR.Subscribe content in the module form (OA-REG-3): {@code <module name>} holding a
     * {@code <triggers>} and a {@code <retrieves>} group. Patterns are validated (OA-MATCH-7).
     *
     * @param module the module's name
     * @param reg the registration
     * @return the content
     * @throws ApiMisuseException for an invalid pattern
     */
    public static String encodeRegistration(String module, Registration reg) {
        Document doc = SafeXml.newDocument();
        Element root = doc.createElement("module");
        SafeXml.setAttr(root, "name", module);
        if (reg.allowSelfTriggering()) {
            SafeXml.setAttr(root, "allowselftriggering", "yes"); // OA-REG-6
        }
        if (!reg.triggers().isEmpty()) {
            Element group = doc.createElement("triggers");
            for (Trigger t : reg.triggers()) {
                group.appendChild(triggerElement(t, doc));
            }
            root.appendChild(group);
        }
        if (!reg.retrieves().isEmpty()) {
            root.appendChild(retrievesElement(reg.retrieves(), doc));
        }
        for (String source : reg.inputStreams()) { // OA-STREAM-14
            if (source == null || source.isEmpty()) {
                throw new ApiMisuseException("an input stream needs a name, type or pattern");
            }
            Element el = doc.createElement("inputstream");
            SafeXml.setAttr(el, "alias", source);
            SafeXml.setAttr(el, "source", source);
            root.appendChild(el);
        }
        return XmlWriter.write(root);
    }

    private static Element triggerElement(Trigger t, Document doc) {
        checkPattern(t.pattern(), "trigger");
        Element el = doc.createElement("trigger");
        SafeXml.setAttr(el, "type", t.pattern());
        if (!t.whiteboard().isEmpty()) {
            SafeXml.setAttr(el, "from", t.whiteboard());
        }
        if (t.afterMs() != 0) {
            SafeXml.setAttr(el, "after", Long.toString(t.afterMs()));
        }
        return el;
    }

    private static void checkPattern(String pattern, String what) {
        String problem = Types.problem(pattern, true);
        if (problem != null) { // OA-MATCH-7: refused before the server has to
            throw new ApiMisuseException(what + " pattern '" + pattern + "' " + problem
                    + " (PATTERN_INVALID)");
        }
    }

    /**
     * Write one {@code <retrieve>} (AIR.Retrieve content); {@code latest} is always written.
     *
     * @param spec the criteria
     * @return the content
     */
    public static String encodeRetrieve(RetrieveSpec spec) {
        return XmlWriter.write(retrieveElement(spec, SafeXml.newDocument()));
    }

    /**
     * Write {@code <retrieves>} (AIR.Retrieves content), at least one spec (OA-RET-10).
     *
     * @param specs the criteria
     * @return the content
     */
    public static String encodeRetrieves(List<RetrieveSpec> specs) {
        if (specs.isEmpty()) {
            throw new ApiMisuseException("a retrieve needs at least one spec");
        }
        return XmlWriter.write(retrievesElement(specs, SafeXml.newDocument()));
    }

    private static Element retrievesElement(List<RetrieveSpec> specs, Document doc) {
        Element group = doc.createElement("retrieves");
        for (RetrieveSpec spec : specs) {
            group.appendChild(retrieveElement(spec, doc));
        }
        return group;
    }

    private static Element retrieveElement(RetrieveSpec spec, Document doc) {
        if (!spec.pattern().isEmpty()) {
            checkPattern(spec.pattern(), "retrieve");
        }
        Element el = doc.createElement("retrieve");
        String[][] attrs = {{"from", spec.whiteboard()}, {"type", spec.pattern()},
            {"id", spec.id()}, {"sender", spec.sender()}, {"content", spec.content()}};
        for (String[] a : attrs) {
            if (!a[1].isEmpty()) {
                SafeXml.setAttr(el, a[0], a[1]);
            }
        }
        textChild(el, "latest", Integer.toString(spec.latest()));
        if (spec.lastmsec() != null) {
            textChild(el, "lastmsec", Long.toString(spec.lastmsec()));
        }
        bound(el, "afterTime", spec.afterTime());
        bound(el, "untilTime", spec.untilTime());
        return el;
    }

    private static void textChild(Element parent, String name, String text) {
        Element child = parent.getOwnerDocument().createElement(name);
        child.appendChild(parent.getOwnerDocument().createTextNode(text));
        parent.appendChild(child);
    }

    /** A time bound: epoch ms as text, or a {@code <time>} child when ms cannot say it all. */
    private static void bound(Element parent, String name, AirTime t) {
        if (t == null) {
            return;
        }
        if (t.usec() == null) {
            textChild(parent, name, Long.toString(t.toEpochMillis()));
            return;
        }
        Element el = parent.getOwnerDocument().createElement(name);
        el.appendChild(TimeXml.timeElement("time", t, parent.getOwnerDocument()));
        parent.appendChild(el);
    }
}
