package org.openair.internal;

import org.openair.ApiMisuseException;
import org.w3c.dom.Element;
import org.w3c.dom.Node;

/**
 * Serializes a DOM subtree in the canonical form of spec 3.5 (spec/vectors/messages README):
 * no declaration, no indentation, attributes in document (or creation) order with double quotes,
 * empty elements as {@code <x/>}; text escapes {@code & < >} and CR, attribute values also
 * {@code "} and TAB/LF/CR; comments and processing instructions inside elements are kept.
 *
 * <p>Characters XML 1.0 does not allow are refused with API_MISUSE (OA-MSG-14): a sender cannot
 * send them.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class XmlWriter {
    private XmlWriter() {}

    /**
     * Serialize an element and everything inside it.
     *
     * @param node the element (or any node)
     * @return the XML text
     */
    public static String write(Node node) {
        StringBuilder sb = new StringBuilder();
        write(node, sb);
        return sb.toString();
    }

    /**
     * Serialize a node into {@code sb}.
     *
     * @param node the node
     * @param sb where the text goes
     */
    public static void write(Node node, StringBuilder sb) {
        switch (node.getNodeType()) {
            case Node.ELEMENT_NODE -> element((Element) node, sb);
            case Node.TEXT_NODE, Node.CDATA_SECTION_NODE -> text(node.getNodeValue(), sb);
            case Node.COMMENT_NODE -> sb.append("<!--").append(checked(node.getNodeValue()))
                    .append("-->");
            case Node.PROCESSING_INSTRUCTION_NODE -> {
                sb.append("<?").append(node.getNodeName());
                String data = node.getNodeValue();
                if (data != null && !data.isEmpty()) {
                    sb.append(' ').append(checked(data));
                }
                sb.append("?>");
            }
            default -> { } // documents, entity references: never built by this library
        }
    }

    private static void element(Element el, StringBuilder sb) {
        String name = el.getTagName();
        sb.append('<').append(name);
        for (String attr : Dom.attributeOrder(el)) {
            sb.append(' ').append(attr).append("=\"");
            attribute(el.getAttribute(attr), sb);
            sb.append('"');
        }
        if (isEmpty(el)) {
            sb.append("/>");
            return;
        }
        sb.append('>');
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            write(n, sb);
        }
        sb.append("</").append(name).append('>');
    }

    private static boolean isEmpty(Element el) {
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            boolean emptyText = n.getNodeType() == Node.TEXT_NODE && n.getNodeValue().isEmpty();
            if (!emptyText) {
                return false;
            }
        }
        return true;
    }

    /**
     * Escape text content: {@code & < >} and CR (as {@code &#13;}).
     *
     * @param s the text
     * @param sb where the escaped text goes
     */
    public static void text(String s, StringBuilder sb) {
        escape(s, sb, false);
    }

    /**
     * Escape an attribute value: {@code & < > "} and TAB, LF, CR.
     *
     * @param s the value
     * @param sb where the escaped value goes
     */
    public static void attrValue(String s, StringBuilder sb) {
        escape(s, sb, true);
    }

    private static void attribute(String s, StringBuilder sb) {
        escape(s, sb, true);
    }

    /* One pass: plain runs are appended whole; a character XML cannot carry is refused. */
    private static void escape(String s, StringBuilder sb, boolean attr) {
        int run = 0;
        int n = s.length();
        for (int i = 0; i < n; i++) {
            char c = s.charAt(i);
            String rep;
            if (c >= 0x3F && c <= 0xD7FF) { // the common case: nothing to escape or check
                continue;
            } else if (c == '&') {
                rep = "&amp;";
            } else if (c == '<') {
                rep = "&lt;";
            } else if (c == '>') {
                rep = "&gt;";
            } else if (c == '\r') {
                rep = "&#13;";
            } else if (attr && c == '"') {
                rep = "&quot;";
            } else if (attr && c == '\t') {
                rep = "&#9;";
            } else if (attr && c == '\n') {
                rep = "&#10;";
            } else if (c >= 0x20 && c <= 0xD7FF || c == '\t' || c == '\n'
                    || c >= 0xE000 && c <= 0xFFFD) {
                continue;
            } else if (Character.isHighSurrogate(c) && i + 1 < n
                    && Character.isLowSurrogate(s.charAt(i + 1))) {
                i++;
                continue;
            } else {
                checked(s); // OA-MSG-14: throws, naming the character
                continue;
            }
            sb.append(s, run, i).append(rep);
            run = i + 1;
        }
        sb.append(s, run, n);
    }

    /**
     * Return {@code s} if every character is allowed by XML 1.0 (OA-MSG-14).
     *
     * @param s the text
     * @return the same text
     * @throws ApiMisuseException naming the first character XML cannot carry
     */
    public static String checked(String s) {
        int bad = firstInvalid(s);
        if (bad >= 0) {
            throw new ApiMisuseException(String.format(
                    "U+%04X cannot be written in XML 1.0 (OA-MSG-14)", s.codePointAt(bad)));
        }
        return s;
    }

    /**
     * Return the index of the first character XML 1.0 does not allow, or -1.
     *
     * @param s the text
     * @return the index, or -1
     */
    public static int firstInvalid(String s) {
        for (int i = 0; i < s.length(); i++) {
            char c = s.charAt(i);
            if (c >= 0x20 && c <= 0xD7FF || c == '\t' || c == '\n' || c == '\r'
                    || c >= 0xE000 && c <= 0xFFFD) {
                continue;
            }
            if (Character.isHighSurrogate(c) && i + 1 < s.length()
                    && Character.isLowSurrogate(s.charAt(i + 1))) {
                i++;
                continue;
            }
            return i;
        }
        return -1;
    }
}
