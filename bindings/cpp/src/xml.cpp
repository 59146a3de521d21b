// The hardened libxml2 parser (spec 14.2) and the lxml-compatible serializer.
#include "xml.hpp"

#include <libxml/xmlerror.h>

#include <climits>
#include <mutex>
#include <utility>

namespace openair::detail {

namespace {

constexpr std::string_view ws = " \t\r\n";
// libxml2 refuses text nodes above 10 000 000 bytes unless XML_PARSE_HUGE is given; a document
// smaller than that cannot hold one, and then libxml2's own depth guard stays on as well.
constexpr std::size_t huge_threshold = 10000000;

void init_libxml2() {
    static std::once_flag once;
    std::call_once(once, [] { xmlInitParser(); });
}

/// Collects the first error libxml2 reports while installed, and keeps it off stderr.
class error_capture {
public:
    error_capture()
        : saved_structured_(xmlStructuredError),
          saved_structured_ctx_(xmlStructuredErrorContext),
          saved_generic_(xmlGenericError),
          saved_generic_ctx_(xmlGenericErrorContext) {
        xmlSetStructuredErrorFunc(this, &error_capture::on_error);
        xmlSetGenericErrorFunc(nullptr, &error_capture::on_generic);
    }
    ~error_capture() {
        xmlSetStructuredErrorFunc(saved_structured_ctx_, saved_structured_);
        xmlSetGenericErrorFunc(saved_generic_ctx_, saved_generic_);
    }
    error_capture(const error_capture&) = delete;
    error_capture& operator=(const error_capture&) = delete;

    int code = 0;
    int line = 0;
    std::string text;

private:
    static void on_error(void* self, xmlErrorPtr err) {
        auto* capture = static_cast<error_capture*>(self);
        if (err == nullptr || capture->code != 0 || err->level == XML_ERR_WARNING) return;
        capture->code = err->code;
        capture->line = err->line;
        capture->text = err->message ? std::string(strip_ws(err->message)) : "parse error";
    }
    static void on_generic(void*, const char*, ...) {}

    xmlStructuredErrorFunc saved_structured_;
    void* saved_structured_ctx_;
    xmlGenericErrorFunc saved_generic_;
    void* saved_generic_ctx_;
};

bool starts_with_ci(std::string_view text, std::size_t at, std::string_view word) {
    if (text.size() - at < word.size()) return false;
    for (std::size_t i = 0; i < word.size(); ++i) {
        char c = text[at + i];
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
        if (c != word[i]) return false;
    }
    return true;
}

/// Refuse any DOCTYPE or entity declaration (OA-SEC-1) and XML that is not UTF-8 (OA-MSG-1).
void check_prolog(std::string_view data) {
    for (std::size_t at = data.find("<!"); at != std::string_view::npos;
         at = data.find("<!", at + 2)) {
        std::size_t i = at + 2;
        while (i < data.size() && ws.find(data[i]) != std::string_view::npos) ++i;
        if (starts_with_ci(data, i, "doctype") || starts_with_ci(data, i, "entity")) {
            throw error(errc::xml_forbidden, "a DOCTYPE or entity declaration is not allowed");
        }
    }
    std::string_view head = data.substr(0, 2);
    if (head == "\xff\xfe" || head == "\xfe\xff" || head == std::string_view("<\0", 2) ||
        head == std::string_view("\0<", 2)) {
        throw error(errc::xml_malformed, "the XML is UTF-16, not UTF-8");
    }
    if (data.substr(0, 5) != "<?xml") return;
    std::string_view decl = data.substr(0, data.find('>'));
    for (std::size_t at = decl.find("encoding"); at != std::string_view::npos;
         at = decl.find("encoding", at + 1)) {
        if (at == 0 || ws.find(decl[at - 1]) == std::string_view::npos) continue;
        std::size_t i = at + 8;
        while (i < decl.size() && ws.find(decl[i]) != std::string_view::npos) ++i;
        if (i >= decl.size() || decl[i] != '=') continue;
        ++i;
        while (i < decl.size() && ws.find(decl[i]) != std::string_view::npos) ++i;
        if (i >= decl.size() || (decl[i] != '"' && decl[i] != '\'')) continue;
        std::size_t end = decl.find(decl[i], i + 1);
        if (end == std::string_view::npos) continue;
        std::string name = ascii_lower(decl.substr(i + 1, end - i - 1));
        if (name != "utf-8") {
            throw error(errc::xml_malformed, "the XML declares encoding '" +
                                                 std::string(decl.substr(i + 1, end - i - 1)) +
                                                 "', not UTF-8");
        }
        return;
    }
}

bool is_entity_error(int code) {
    switch (code) {
        case XML_ERR_UNDECLARED_ENTITY:
        case XML_WAR_UNDECLARED_ENTITY:
        case XML_ERR_UNPARSED_ENTITY:
        case XML_ERR_ENTITY_IS_EXTERNAL:
        case XML_ERR_ENTITY_IS_PARAMETER:
        case XML_ERR_ENTITY_LOOP:
        case XML_ERR_ENTITY_BOUNDARY:
        case XML_ERR_ENTITY_PE_INTERNAL:
        case XML_ERR_EXT_ENTITY_STANDALONE: return true;
        default: return false;
    }
}

[[noreturn]] void raise_parse_error(const error_capture& capture) {
    std::string detail = capture.text.empty() ? "not well-formed" : capture.text;
    if (capture.line > 0) detail += " at line " + std::to_string(capture.line);
    if (is_entity_error(capture.code))
        throw error(errc::xml_forbidden, "entity not allowed: " + detail);
    if (capture.text.find("Excessive depth") != std::string::npos) {
        throw error(errc::xml_too_deep, detail);
    }
    throw error(errc::xml_malformed, detail);
}

/// Raise XML_TOO_DEEP when an element lies deeper than `limit` (the root is depth 1).
void check_depth(const xmlNode* root, std::size_t limit) {
    std::vector<std::pair<const xmlNode*, std::size_t>> stack{{root, 1}};
    while (!stack.empty()) {
        auto [node, depth] = stack.back();
        stack.pop_back();
        if (depth > limit) {
            throw error(errc::xml_too_deep,
                        "element nesting deeper than " + std::to_string(limit));  // OA-LIM-3
        }
        for (const xmlNode* c = node->children; c != nullptr; c = c->next) {
            if (is_element(c)) stack.emplace_back(c, depth + 1);
        }
    }
}

void append_qname(std::string& out, const xmlNs* ns, std::string_view name) {
    if (ns != nullptr && ns->prefix != nullptr) {
        out += reinterpret_cast<const char*>(ns->prefix);
        out += ':';
    }
    out += name;
}

void append_ns_decl(std::string& out, const xmlNs* ns) {
    out += " xmlns";
    if (ns->prefix != nullptr) {
        out += ':';
        out += reinterpret_cast<const char*>(ns->prefix);
    }
    out += "=\"";
    escape_attr(out, ns->href ? reinterpret_cast<const char*>(ns->href) : "", "namespace");
    out += '"';
}

/// Namespaces used inside the subtree of `top` but declared outside it (lxml repeats those on
/// the serialized element, so that the text stands on its own).
std::vector<const xmlNs*> outside_namespaces(const xmlNode* top) {
    std::vector<const xmlNs*> used;
    std::vector<const xmlNs*> declared;
    std::vector<const xmlNode*> stack{top};
    auto note = [&used](const xmlNs* ns) {
        if (ns == nullptr || (ns->prefix != nullptr && xmlStrEqual(ns->prefix, BAD_CAST "xml")))
            return;
        for (const xmlNs* u : used) {
            if (u == ns) return;
        }
        used.push_back(ns);
    };
    while (!stack.empty()) {
        const xmlNode* n = stack.back();
        stack.pop_back();
        for (const xmlNs* d = n->nsDef; d != nullptr; d = d->next) declared.push_back(d);
        note(n->ns);
        for (const xmlAttr* a = n->properties; a != nullptr; a = a->next) note(a->ns);
        for (const xmlNode* c = n->last; c != nullptr; c = c->prev) {
            if (is_element(c)) stack.push_back(c);
        }
    }
    std::vector<const xmlNs*> out;
    for (const xmlNs* u : used) {
        bool inside = false;
        for (const xmlNs* d : declared) inside = inside || d == u;
        if (!inside) out.push_back(u);
    }
    return out;
}

void serialize_into(std::string& out, const xmlNode* top);

void serialize_node(std::string& out, const xmlNode* n) {
    switch (n->type) {
        case XML_ELEMENT_NODE: serialize_into(out, n); break;
        case XML_TEXT_NODE:
        case XML_CDATA_SECTION_NODE: escape_text(out, node_content(n), "text"); break;
        case XML_COMMENT_NODE:
            out += "<!--";
            out += node_content(n);
            out += "-->";
            break;
        case XML_PI_NODE:
            out += "<?";
            out += node_name(n);
            if (!node_content(n).empty()) {
                out += ' ';
                out += node_content(n);
            }
            out += "?>";
            break;
        case XML_ENTITY_REF_NODE:
            out += '&';
            out += node_name(n);
            out += ';';
            break;
        default: break;
    }
}

/// Serialize elements iteratively: depth is bounded by the parser, but never by the stack.
void serialize_into(std::string& out, const xmlNode* top) {
    struct entry {
        const xmlNode* node;
        bool closing;
    };
    std::vector<entry> stack{{top, false}};
    std::vector<const xmlNs*> extra = outside_namespaces(top);
    while (!stack.empty()) {
        entry e = stack.back();
        stack.pop_back();
        const xmlNode* n = e.node;
        if (e.closing) {
            out += "</";
            append_qname(out, n->ns, node_name(n));
            out += '>';
            continue;
        }
        if (!is_element(n)) {
            serialize_node(out, n);
            continue;
        }
        out += '<';
        append_qname(out, n->ns, node_name(n));
        if (n == top) {
            for (const xmlNs* ns : extra) append_ns_decl(out, ns);
        }
        for (const xmlNs* d = n->nsDef; d != nullptr; d = d->next) append_ns_decl(out, d);
        for (const xmlAttr* a = n->properties; a != nullptr; a = a->next) {
            out += ' ';
            append_qname(out, a->ns, reinterpret_cast<const char*>(a->name));
            out += "=\"";
            escape_attr(out, attr_value(a), "attribute");
            out += '"';
        }
        if (n->children == nullptr) {
            out += "/>";
            continue;
        }
        out += '>';
        stack.push_back({n, true});
        for (const xmlNode* c = n->last; c != nullptr; c = c->prev) stack.push_back({c, false});
    }
}

/// Decode one UTF-8 sequence at `i`; returns the code point and advances `i`, or -1 if invalid.
long decode_utf8(std::string_view s, std::size_t& i) {
    auto b = static_cast<unsigned char>(s[i]);
    if (b < 0x80) {
        ++i;
        return b;
    }
    std::size_t len = b >= 0xF0 ? 4 : b >= 0xE0 ? 3 : b >= 0xC2 ? 2 : 0;
    if (len == 0 || b > 0xF4 || i + len > s.size()) return -1;
    long cp = b & (0x7F >> len);
    for (std::size_t k = 1; k < len; ++k) {
        auto c = static_cast<unsigned char>(s[i + k]);
        if ((c & 0xC0) != 0x80) return -1;
        cp = (cp << 6) | (c & 0x3F);
    }
    if ((len == 3 && cp < 0x800) || (len == 4 && (cp < 0x10000 || cp > 0x10FFFF))) return -1;
    if (cp >= 0xD800 && cp <= 0xDFFF) return -1;
    i += len;
    return cp;
}

bool is_xml_char(long cp) {
    return cp == 0x9 || cp == 0xA || cp == 0xD || (cp >= 0x20 && cp <= 0xD7FF) ||
           (cp >= 0xE000 && cp <= 0xFFFD) || (cp >= 0x10000 && cp <= 0x10FFFF);
}

std::string hex_code(long cp) {
    static const char digits[] = "0123456789ABCDEF";
    std::string out;
    for (int shift = cp > 0xFFFF ? 20 : 12; shift >= 0; shift -= 4)
        out += digits[(cp >> shift) & 0xF];
    return "U+" + out;
}

template <typename Escape>
void escape_checked(std::string& out, std::string_view text, std::string_view what, Escape esc) {
    std::size_t i = 0;
    while (i < text.size()) {
        std::size_t start = i;
        long cp = decode_utf8(text, i);
        if (cp < 0) {
            throw error(errc::api_misuse, std::string(what) + " is not valid UTF-8 (OA-MSG-14)");
        }
        if (!is_xml_char(cp)) {
            throw error(errc::api_misuse, std::string(what) + " holds " + hex_code(cp) +
                                              ", which XML 1.0 does not allow (OA-MSG-14)");
        }
        if (!esc(out, cp)) out.append(text.substr(start, i - start));
    }
}

}  // namespace

// -- parsing ---------------------------------------------------------------------------------

doc_ptr parse_document(std::string_view data, const xml_limits& limits) {
    if (data.size() > limits.max_bytes) {
        throw error(errc::xml_malformed, "document of " + std::to_string(data.size()) +
                                             " bytes exceeds " + std::to_string(limits.max_bytes));
    }
    if (data.size() > static_cast<std::size_t>(INT_MAX)) {
        throw error(errc::xml_malformed, "document too large for the parser");
    }
    check_prolog(data);
    if (is_blank(data)) throw error(errc::xml_malformed, "empty document");
    init_libxml2();
    error_capture capture;
    ctxt_ptr ctxt(xmlNewParserCtxt());
    if (!ctxt) throw std::bad_alloc();
    // OA-SEC-2: no network, no DTD loading, no entity substitution (never XML_PARSE_NOENT or
    // XML_PARSE_DTDLOAD); CDATA becomes text; errors are collected, not printed.
    int options = XML_PARSE_NONET | XML_PARSE_NOCDATA | XML_PARSE_NOERROR | XML_PARSE_NOWARNING;
    if (data.size() >= huge_threshold) options |= XML_PARSE_HUGE;
    doc_ptr doc(xmlCtxtReadMemory(ctxt.get(), data.data(), static_cast<int>(data.size()), nullptr,
                                  "UTF-8", options));
    if (!doc || !ctxt->wellFormed || !ctxt->nsWellFormed) raise_parse_error(capture);
    if (doc->intSubset != nullptr || doc->extSubset != nullptr) {
        throw error(errc::xml_forbidden, "a DOCTYPE is not allowed");  // OA-SEC-1
    }
    const xmlNode* root = xmlDocGetRootElement(doc.get());
    if (root == nullptr) throw error(errc::xml_malformed, "empty document");
    check_depth(root, limits.max_depth);
    return doc;
}

doc_ptr parse_wrapped(std::string_view text, const xml_limits& limits) {
    std::string wrapped;
    wrapped.reserve(text.size() + 7);
    wrapped.append("<x>").append(text).append("</x>");
    xml_limits inner{limits.max_bytes + 7, limits.max_depth + 1};
    return parse_document(wrapped, inner);
}

fragment parse_fragment(std::string_view text, const xml_limits& limits) {
    fragment out{parse_wrapped(text, limits), {}};
    for (const child_item& item : child_items(xmlDocGetRootElement(out.doc.get()))) {
        if (item.node == nullptr && !is_blank(item.text)) {
            throw error(errc::xml_malformed, "text outside the elements of XML content");
        }
        if (item.node != nullptr && is_element(item.node)) {
            out.elements.push_back(const_cast<xmlNode*>(item.node));
        }
    }
    return out;
}

// -- reading ---------------------------------------------------------------------------------

std::string ascii_lower(std::string_view text) {
    std::string out(text);
    for (char& c : out) {
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    }
    return out;
}

std::string local_name(const xmlNode* n) {
    return ascii_lower(node_name(n));
}

bool is_blank(std::string_view text) noexcept {
    return text.find_first_not_of(ws) == std::string_view::npos;
}

std::string_view strip_ws(std::string_view text) noexcept {
    std::size_t start = text.find_first_not_of(ws);
    if (start == std::string_view::npos) return {};
    std::size_t end = text.find_last_not_of(ws);
    return text.substr(start, end - start + 1);
}

std::vector<xmlNode*> child_elements(const xmlNode* n) {
    std::vector<xmlNode*> out;
    for (xmlNode* c = n->children; c != nullptr; c = c->next) {
        if (is_element(c)) out.push_back(c);
    }
    return out;
}

std::string attr_value(const xmlAttr* a) {
    std::string out;
    for (const xmlNode* c = a->children; c != nullptr; c = c->next) {
        if (is_text(c)) out += node_content(c);
    }
    return out;
}

std::optional<std::string> attr(const xmlNode* n, std::string_view name) {
    std::string wanted = ascii_lower(name);
    for (const xmlAttr* a = n->properties; a != nullptr; a = a->next) {
        if (ascii_lower(reinterpret_cast<const char*>(a->name)) == wanted) return attr_value(a);
    }
    return std::nullopt;
}

std::vector<child_item> child_items(const xmlNode* n) {
    std::vector<child_item> out;
    bool in_run = false;
    for (const xmlNode* c = n->children; c != nullptr; c = c->next) {
        if (is_text(c)) {
            if (!in_run) out.push_back({nullptr, {}});
            out.back().text += node_content(c);
            in_run = true;
        } else {
            out.push_back({c, {}});
            in_run = false;
        }
    }
    return out;
}

std::optional<std::string> text_only(const xmlNode* n, const xmlNode** offender) {
    std::string out;
    for (const xmlNode* c = n->children; c != nullptr; c = c->next) {
        if (is_text(c)) {
            out += node_content(c);
        } else if (is_element(c)) {
            if (offender != nullptr) *offender = c;
            return std::nullopt;
        }
    }
    return out;
}

std::string inner_text(const xmlNode* n) {
    std::string out;
    std::vector<const xmlNode*> stack;
    for (const xmlNode* c = n->last; c != nullptr; c = c->prev) stack.push_back(c);
    while (!stack.empty()) {
        const xmlNode* c = stack.back();
        stack.pop_back();
        if (is_text(c)) out += node_content(c);
        if (is_element(c)) {
            for (const xmlNode* k = c->last; k != nullptr; k = k->prev) stack.push_back(k);
        }
    }
    return out;
}

std::string serialize(const xmlNode* n) {
    std::string out;
    serialize_into(out, n);
    return out;
}

std::string inner_mixed(const xmlNode* n) {
    std::string out;
    for (const child_item& item : child_items(n)) {
        if (item.node == nullptr) {
            if (!is_blank(item.text)) escape_text(out, item.text, "text");
        } else if (is_element(item.node)) {
            serialize_into(out, item.node);
        }
    }
    return out;
}

std::string inner_all(const xmlNode* n) {
    std::string out;
    for (const xmlNode* c = n->children; c != nullptr; c = c->next) serialize_node(out, c);
    return out;
}

// -- writing ---------------------------------------------------------------------------------

void escape_text(std::string& out, std::string_view text, std::string_view what) {
    escape_checked(out, text, what, [](std::string& o, long cp) {
        switch (cp) {
            case '&': o += "&amp;"; return true;
            case '<': o += "&lt;"; return true;
            case '>': o += "&gt;"; return true;
            case '\r': o += "&#13;"; return true;
            default: return false;
        }
    });
}

void escape_attr(std::string& out, std::string_view text, std::string_view what) {
    escape_checked(out, text, what, [](std::string& o, long cp) {
        switch (cp) {
            case '&': o += "&amp;"; return true;
            case '<': o += "&lt;"; return true;
            case '>': o += "&gt;"; return true;
            case '"': o += "&quot;"; return true;
            case '\t': o += "&#9;"; return true;
            case '\n': o += "&#10;"; return true;
            case '\r': o += "&#13;"; return true;
            default: return false;
        }
    });
}

bool is_xml_name(std::string_view name) {
    if (name.empty() || name.size() > 50000) return false;
    std::string copy(name);
    // xmlValidateName(..., 0) checks the XML 1.0 Name production without namespaces.
    return xmlValidateName(reinterpret_cast<const xmlChar*>(copy.c_str()), 0) == 0 &&
           copy.find(':') == std::string::npos;
}

void xml_writer::finish_start() {
    if (start_open_) {
        out_ += '>';
        start_open_ = false;
    }
}

void xml_writer::open(std::string_view name) {
    finish_start();
    out_ += '<';
    out_ += name;
    open_.emplace_back(name);
    start_open_ = true;
}

void xml_writer::attribute(std::string_view name, std::string_view value, std::string_view what) {
    out_ += ' ';
    out_ += name;
    out_ += "=\"";
    escape_attr(out_, value, what.empty() ? name : what);
    out_ += '"';
}

void xml_writer::text(std::string_view value, std::string_view what) {
    if (value.empty()) return;
    finish_start();
    escape_text(out_, value, what.empty() ? std::string_view(open_.back()) : what);
}

void xml_writer::raw(std::string_view xml) {
    if (xml.empty()) return;
    finish_start();
    out_ += xml;
}

void xml_writer::close() {
    if (start_open_) {
        out_ += "/>";
        start_open_ = false;
    } else {
        out_ += "</";
        out_ += open_.back();
        out_ += '>';
    }
    open_.pop_back();
}

void xml_writer::text_element(std::string_view name, std::string_view value,
                              std::string_view what) {
    open(name);
    text(value, what.empty() ? name : what);
    close();
}

}  // namespace openair::detail
