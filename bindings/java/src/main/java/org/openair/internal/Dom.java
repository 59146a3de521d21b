package org.openair.internal;

import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Locale;
import java.util.Map;
import org.w3c.dom.Attr;
import org.w3c.dom.Element;
import org.w3c.dom.NamedNodeMap;
import org.w3c.dom.Node;

/**
 * Small DOM helpers: names compared in any ASCII case (OA-MSG-3), text and child elements.
 *
 * <p>Threading: stateless; thread-safe (DOM trees themselves are not).
 */
public final class Dom {
    private Dom() {}

    /**
     * Return whether {@code s} holds only XML white space (space, tab, CR, LF).
     *
     * @param s the text (null counts as blank)
     * @return whether it is blank
     */
    public static boolean isBlank(String s) {
        if (s == null) {
            return true;
        }
        for (int i = 0; i < s.length(); i++) {
            char c = s.charAt(i);
            if (c != ' ' && c != '\t' && c != '\r' && c != '\n') {
                return false;
            }
        }
        return true;
    }

    /**
     * Strip XML white space from both ends.
     *
     * @param s the text
     * @return the stripped text
     */
    public static String strip(String s) {
        int start = 0;
        int end = s.length();
        while (start < end && isSpace(s.charAt(start))) {
            start++;
        }
        while (end > start && isSpace(s.charAt(end - 1))) {
            end--;
        }
        return s.substring(start, end);
    }

    private static boolean isSpace(char c) {
        return c == ' ' || c == '\t' || c == '\r' || c == '\n';
    }

    /**
     * Return a node name without prefix, lower-cased in ASCII (OA-MSG-3).
     *
     * @param name the name as written
     * @return the folded local name
     */
    public static String fold(String name) {
        int colon = name.indexOf(':');
        String local = colon >= 0 ? name.substring(colon + 1) : name;
        return local.toLowerCase(Locale.ROOT);
    }

    /**
     * Return the folded local name of an element.
     *
     * @param el the element
     * @return its name in lower case
     */
    public static String name(Element el) {
        return fold(el.getTagName());
    }

    /**
     * Return the child elements of {@code el}, in order.
     *
     * @param el the parent
     * @return its element children
     */
    public static List<Element> children(Element el) {
        List<Element> out = new ArrayList<>();
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.ELEMENT_NODE) {
                out.add((Element) n);
            }
        }
        return out;
    }

    /**
     * Return whether {@code el} has an element child.
     *
     * @param el the element
     * @return whether it holds elements
     */
    public static boolean hasElements(Element el) {
        for (Node n = el.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.ELEMENT_NODE) {
                return true;
            }
        }
        return false;
    }

    /**
     * Return the attributes of {@code el} keyed by folded name, in document order.
     *
     * @param el the element
     * @return the attributes (the first of two spellings of one name wins)
     */
    public static Map<String, String> attributes(Element el) {
        Map<String, String> out = new LinkedHashMap<>();
        for (String name : attributeOrder(el)) {
            out.putIfAbsent(fold(name), el.getAttribute(name));
        }
        return out;
    }

    /**
     * Return the attribute names of {@code el} in document (or creation) order.
     *
     * @param el the element
     * @return the names
     */
    public static List<String> attributeOrder(Element el) {
        NamedNodeMap attrs = el.getAttributes();
        List<String> out = new ArrayList<>(attrs.getLength());
        String[] order = (String[]) el.getUserData(SafeXml.ORDER);
        if (order != null) {
            for (String name : order) {
                if (el.hasAttribute(name)) {
                    out.add(name);
                }
            }
        }
        for (int i = 0; i < attrs.getLength(); i++) {
            String name = ((Attr) attrs.item(i)).getName();
            if (!out.contains(name)) {
                out.add(name);
            }
        }
        return out;
    }

    /**
     * Return an attribute by folded name (any case, OA-MSG-3).
     *
     * @param el the element
     * @param folded the lower-case name
     * @return the value, or null when absent
     */
    public static String attr(Element el, String folded) {
        NamedNodeMap attrs = el.getAttributes();
        for (int i = 0; i < attrs.getLength(); i++) {
            Attr a = (Attr) attrs.item(i);
            if (fold(a.getName()).equals(folded)) {
                return a.getValue();
            }
        }
        return null;
    }

    /**
     * Return the concatenated text of all descendants of {@code el} (comments skipped).
     *
     * @param el the element
     * @return its text
     */
    public static String innerText(Element el) {
        StringBuilder sb = new StringBuilder();
        appendText(el, sb);
        return sb.toString();
    }

    private static void appendText(Node node, StringBuilder sb) {
        for (Node n = node.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.TEXT_NODE || n.getNodeType() == Node.CDATA_SECTION_NODE) {
                sb.append(n.getNodeValue());
            } else if (n.getNodeType() == Node.ELEMENT_NODE) {
                appendText(n, sb);
            }
        }
    }
}
