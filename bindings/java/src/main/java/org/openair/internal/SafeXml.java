package org.openair.internal;

import java.io.ByteArrayInputStream;
import java.io.IOException;
import java.nio.charset.StandardCharsets;
import java.util.ArrayDeque;
import java.util.ArrayList;
import java.util.Deque;
import java.util.List;
import java.util.Locale;
import java.util.Set;
import java.util.regex.Matcher;
import java.util.regex.Pattern;
import javax.xml.XMLConstants;
import javax.xml.parsers.DocumentBuilder;
import javax.xml.parsers.DocumentBuilderFactory;
import javax.xml.parsers.ParserConfigurationException;
import javax.xml.parsers.SAXParser;
import javax.xml.parsers.SAXParserFactory;
import org.openair.ErrorCode;
import org.openair.OpenAirException;
import org.openair.RemoteProtocolException;
import org.w3c.dom.Document;
import org.w3c.dom.Element;
import org.w3c.dom.Node;
import org.w3c.dom.Text;
import org.xml.sax.Attributes;
import org.xml.sax.InputSource;
import org.xml.sax.SAXException;
import org.xml.sax.SAXParseException;
import org.xml.sax.XMLReader;
import org.xml.sax.ext.DefaultHandler2;

/**
 * The one hardened XML parser of the library (spec 14.2, OA-SEC-1/2, OA-LIM-3; style rule 6).
 *
 * <p>A DOCTYPE or entity declaration anywhere is XML_FORBIDDEN (checked on the bytes before
 * parsing, and the parser is configured with {@code disallow-doctype-decl} as well); no DTD is
 * loaded, no external entity is resolved, XInclude is off and secure processing is on; entities
 * other than the five predefined ones are refused; documents are bounded in size and element depth.
 * Only UTF-8 is accepted (OA-MSG-1).
 *
 * <p>Parsing builds an {@code org.w3c.dom} tree through SAX rather than
 * {@code DocumentBuilder.parse}: the JDK DOM keeps attributes sorted by name, while the canonical
 * form keeps them in document order (spec/vectors/messages README), so the builder records each
 * element's attribute order as user data ({@link #ORDER}) and {@link XmlWriter} honours it.
 * Elements built by the codec record their order the same way ({@link #setAttr}).
 *
 * <p>Threading: thread-safe; parsers and builders are per thread.
 */
public final class SafeXml {
    /** The default element depth limit (OA-LIM-3). */
    public static final int DEFAULT_MAX_DEPTH = 64;
    /** The default document size limit (OA-LIM-1). */
    public static final int DEFAULT_MAX_BYTES = 16 * 1024 * 1024;
    /** User-data key under which an element keeps its attribute names in document order. */
    public static final String ORDER = "openair.attribute-order";

    private static final Pattern DECLARATION =
            Pattern.compile("<!\\s*(?:doctype|entity)", Pattern.CASE_INSENSITIVE);
    private static final Pattern DECLARED_ENCODING = Pattern.compile(
            "<\\?xml[^>]*?\\sencoding\\s*=\\s*[\"']([A-Za-z0-9._-]*)[\"']");
    private static final Pattern ENTITY_REF = Pattern.compile("&([^#;\\s&<>]+);");
    private static final Set<String> PREDEFINED = Set.of("lt", "gt", "amp", "quot", "apos");

    private static final SAXParserFactory SAX = saxFactory();
    private static final DocumentBuilderFactory DOM = domFactory();
    private static final ThreadLocal<SAXParser> PARSER = ThreadLocal.withInitial(SafeXml::newParser);
    private static final ThreadLocal<DocumentBuilder> BUILDER =
            ThreadLocal.withInitial(SafeXml::newBuilder);

    private SafeXml() {}

    private static SAXParserFactory saxFactory() {
        try {
            SAXParserFactory f = SAXParserFactory.newInstance();
            f.setNamespaceAware(false);
            f.setValidating(false);
            f.setXIncludeAware(false);
            f.setFeature(XMLConstants.FEATURE_SECURE_PROCESSING, true);
            f.setFeature("http://apache.org/xml/features/disallow-doctype-decl", true); // OA-SEC-1
            f.setFeature("http://xml.org/sax/features/external-general-entities", false);
            f.setFeature("http://xml.org/sax/features/external-parameter-entities", false);
            f.setFeature("http://apache.org/xml/features/nonvalidating/load-external-dtd", false);
            return f;
        } catch (ParserConfigurationException | SAXException e) {
            throw new IllegalStateException("cannot configure a hardened XML parser", e);
        }
    }

    /** The factory of the documents the builder fills (hardened too, although it never parses). */
    private static DocumentBuilderFactory domFactory() {
        try {
            DocumentBuilderFactory f = DocumentBuilderFactory.newInstance();
            f.setNamespaceAware(false);
            f.setValidating(false);
            f.setXIncludeAware(false);
            f.setExpandEntityReferences(false);
            f.setFeature(XMLConstants.FEATURE_SECURE_PROCESSING, true);
            f.setFeature("http://apache.org/xml/features/disallow-doctype-decl", true);
            f.setFeature("http://xml.org/sax/features/external-general-entities", false);
            f.setFeature("http://xml.org/sax/features/external-parameter-entities", false);
            f.setFeature("http://apache.org/xml/features/nonvalidating/load-external-dtd", false);
            f.setAttribute(XMLConstants.ACCESS_EXTERNAL_DTD, "");
            f.setAttribute(XMLConstants.ACCESS_EXTERNAL_SCHEMA, "");
            return f;
        } catch (ParserConfigurationException e) {
            throw new IllegalStateException("cannot configure a hardened DOM factory", e);
        }
    }

    private static SAXParser newParser() {
        try {
            SAXParser p = SAX.newSAXParser();
            p.setProperty(XMLConstants.ACCESS_EXTERNAL_DTD, ""); // OA-SEC-2: no file, no network
            p.setProperty(XMLConstants.ACCESS_EXTERNAL_SCHEMA, "");
            return p;
        } catch (ParserConfigurationException | SAXException e) {
            throw new IllegalStateException("cannot create a hardened XML parser", e);
        }
    }

    private static DocumentBuilder newBuilder() {
        try {
            return DOM.newDocumentBuilder();
        } catch (ParserConfigurationException e) {
            throw new IllegalStateException("cannot create a DOM builder", e);
        }
    }

    /** @return a new empty document to build elements in */
    public static Document newDocument() {
        return BUILDER.get().newDocument();
    }

    /**
     * Parse one whole document and return its root element.
     *
     * @param data the document's bytes (UTF-8)
     * @param maxBytes the size limit
     * @param maxDepth the depth limit (the root is depth 1)
     * @return the root element
     * @throws RemoteProtocolException XML_FORBIDDEN, XML_TOO_DEEP or XML_MALFORMED
     */
    public static Element parse(byte[] data, long maxBytes, int maxDepth) {
        if (data.length > maxBytes) {
            throw malformed("document of " + data.length + " bytes exceeds " + maxBytes);
        }
        checkProlog(data);
        Document doc = newDocument();
        parseInto(data, doc, maxDepth);
        Element root = doc.getDocumentElement();
        if (root == null) {
            throw malformed("empty document");
        }
        return root;
    }

    /**
     * Parse XML content: zero or more sibling elements (OA-MSG-10). Whitespace between them is
     * ignored (OA-MSG-17); other text at the top level is XML_MALFORMED.
     *
     * @param text the content
     * @param maxDepth the depth limit, counted from the first content element
     * @return the top-level elements
     */
    public static List<Element> parseFragment(String text, int maxDepth) {
        Element wrapper = parseWrapped(text, maxDepth);
        List<Element> out = new ArrayList<>();
        for (Node n = wrapper.getFirstChild(); n != null; n = n.getNextSibling()) {
            if (n.getNodeType() == Node.ELEMENT_NODE) {
                out.add((Element) n);
            } else if (n.getNodeType() == Node.TEXT_NODE && !Dom.isBlank(n.getNodeValue())) {
                throw malformed("text outside the elements of XML content");
            }
        }
        return out;
    }

    /**
     * Parse inner XML (elements and text) wrapped in one element, which is returned.
     *
     * @param text the inner XML
     * @param maxDepth the depth limit below the wrapper
     * @return the wrapper element, holding the parsed nodes
     */
    public static Element parseWrapped(String text, int maxDepth) {
        byte[] body = text.getBytes(StandardCharsets.UTF_8);
        byte[] data = new byte[body.length + 7];
        System.arraycopy("<c>".getBytes(StandardCharsets.US_ASCII), 0, data, 0, 3);
        System.arraycopy(body, 0, data, 3, body.length);
        System.arraycopy("</c>".getBytes(StandardCharsets.US_ASCII), 0, data, 3 + body.length, 4);
        return parse(data, (long) DEFAULT_MAX_BYTES + 7, maxDepth + 1);
    }

    private static void checkProlog(byte[] data) {
        String head = new String(data, StandardCharsets.ISO_8859_1); // byte-for-byte, for regexes
        if (head.contains("<!") && DECLARATION.matcher(head).find()) {
            throw forbidden("a DOCTYPE or entity declaration is not allowed"); // OA-SEC-1
        }
        if (data.length >= 2 && isUtf16Start(data[0], data[1])) {
            throw malformed("the XML is UTF-16, not UTF-8"); // OA-MSG-1
        }
        if (head.startsWith("<?xml")) {
            Matcher m = DECLARED_ENCODING.matcher(head);
            if (m.lookingAt() && !m.group(1).toLowerCase(Locale.ROOT).equals("utf-8")) {
                throw malformed("the XML declares encoding '" + m.group(1) + "', not UTF-8");
            }
        }
    }

    private static boolean isUtf16Start(byte a, byte b) {
        return (a == (byte) 0xff && b == (byte) 0xfe) || (a == (byte) 0xfe && b == (byte) 0xff)
                || (a == '<' && b == 0) || (a == 0 && b == '<');
    }

    private static void parseInto(byte[] data, Document doc, int maxDepth) {
        SAXParser parser = PARSER.get();
        Builder handler = new Builder(doc, maxDepth);
        try {
            XMLReader reader = parser.getXMLReader();
            reader.setContentHandler(handler);
            reader.setErrorHandler(handler);
            reader.setEntityResolver(handler);
            reader.setProperty("http://xml.org/sax/properties/lexical-handler", handler);
            InputSource source = new InputSource(new ByteArrayInputStream(data));
            source.setEncoding("UTF-8");
            reader.parse(source);
        } catch (TooDeep e) {
            throw new RemoteProtocolException(ErrorCode.XML_TOO_DEEP, e.getMessage());
        } catch (SAXException | IOException | RuntimeException e) {
            PARSER.remove(); // a parser that failed half-way is not reused
            if (e instanceof OpenAirException oa) {
                throw oa;
            }
            throw classify(data, e);
        } finally {
            parser.reset();
        }
    }

    private static RemoteProtocolException classify(byte[] data, Exception e) {
        String text = describe(e);
        Matcher m = ENTITY_REF.matcher(new String(data, StandardCharsets.UTF_8));
        while (m.find()) {
            if (!PREDEFINED.contains(m.group(1))) {
                return forbidden("entity not allowed: " + text); // OA-SEC-2
            }
        }
        return malformed(text);
    }

    private static String describe(Exception e) {
        if (e instanceof SAXParseException p) {
            return p.getMessage() + " (line " + p.getLineNumber() + ", column "
                    + p.getColumnNumber() + ")";
        }
        return String.valueOf(e.getMessage());
    }

    static RemoteProtocolException malformed(String detail) {
        return new RemoteProtocolException(ErrorCode.XML_MALFORMED, detail);
    }

    static RemoteProtocolException forbidden(String detail) {
        return new RemoteProtocolException(ErrorCode.XML_FORBIDDEN, detail);
    }

    /**
     * Set an attribute and record it at the end of the element's attribute order.
     *
     * @param el the element
     * @param name the attribute name
     * @param value its value
     */
    public static void setAttr(Element el, String name, String value) {
        String[] order = (String[]) el.getUserData(ORDER);
        if (!el.hasAttribute(name)) {
            String[] grown = order == null ? new String[1] : java.util.Arrays.copyOf(
                    order, order.length + 1);
            grown[grown.length - 1] = name;
            el.setUserData(ORDER, grown, null);
        }
        el.setAttribute(name, value);
    }

    /** Thrown inside the SAX callbacks when the depth limit is passed. */
    private static final class TooDeep extends SAXException {
        private static final long serialVersionUID = 1L;

        TooDeep(String message) {
            super(message);
        }
    }

    /** Builds the DOM from SAX events, keeping attribute order and refusing deep nesting. */
    private static final class Builder extends DefaultHandler2 {
        private final Document doc;
        private final int maxDepth;
        private final Deque<Node> open = new ArrayDeque<>();

        Builder(Document doc, int maxDepth) {
            this.doc = doc;
            this.maxDepth = maxDepth;
            open.push(doc);
        }

        @Override
        public void startElement(String uri, String local, String qName, Attributes atts)
                throws SAXException {
            if (open.size() > maxDepth) { // the document node is on the stack too
                throw new TooDeep("element nesting deeper than " + maxDepth); // OA-LIM-3
            }
            Element el = doc.createElement(qName);
            for (int i = 0; i < atts.getLength(); i++) {
                setAttr(el, atts.getQName(i), atts.getValue(i));
            }
            open.peek().appendChild(el);
            open.push(el);
        }

        @Override
        public void endElement(String uri, String local, String qName) {
            open.pop();
        }

        @Override
        public void characters(char[] ch, int start, int length) {
            Node parent = open.peek();
            if (parent == doc || length == 0) {
                return; // only white space can sit outside the root
            }
            Node last = parent.getLastChild();
            String text = new String(ch, start, length);
            if (last != null && last.getNodeType() == Node.TEXT_NODE) {
                ((Text) last).appendData(text); // CDATA and split text merge, as lxml reads them
            } else {
                parent.appendChild(doc.createTextNode(text));
            }
        }

        @Override
        public void ignorableWhitespace(char[] ch, int start, int length) {
            characters(ch, start, length);
        }

        @Override
        public void processingInstruction(String target, String data) {
            Node parent = open.peek();
            if (parent != doc) {
                parent.appendChild(doc.createProcessingInstruction(target, data));
            }
        }

        @Override
        public void comment(char[] ch, int start, int length) {
            Node parent = open.peek();
            if (parent != doc) {
                parent.appendChild(doc.createComment(new String(ch, start, length)));
            }
        }

        @Override
        public void startDTD(String name, String publicId, String systemId) {
            throw forbidden("a DOCTYPE is not allowed"); // OA-SEC-1
        }

        @Override
        public InputSource resolveEntity(String name, String publicId, String baseUri,
                String systemId) {
            return new InputSource(new ByteArrayInputStream(new byte[0])); // never fetch (OA-SEC-2)
        }

        @Override
        public void warning(SAXParseException e) {
            // a warning does not make the document ill-formed
        }

        @Override
        public void error(SAXParseException e) throws SAXException {
            throw e;
        }

        @Override
        public void fatalError(SAXParseException e) throws SAXException {
            throw e;
        }
    }
}
