// Internal: the one hardened libxml2 parser and the XML text writer (spec 14.2, OA-SEC-1/2,
// OA-LIM-3). Never included from a public header: libxml2 stays an implementation detail.
#pragma once

#include <libxml/parser.h>
#include <libxml/tree.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "openair/codec.hpp"
#include "openair/error.hpp"

namespace openair::detail {

/// The one deleter for every libxml2 object the library owns.
struct xml_deleter {
    void operator()(xmlDoc* doc) const noexcept { xmlFreeDoc(doc); }
    void operator()(xmlParserCtxt* ctxt) const noexcept { xmlFreeParserCtxt(ctxt); }
    void operator()(xmlChar* text) const noexcept { xmlFree(text); }
};

using doc_ptr = std::unique_ptr<xmlDoc, xml_deleter>;
using ctxt_ptr = std::unique_ptr<xmlParserCtxt, xml_deleter>;

/// Parse one whole XML document. Throws XML_FORBIDDEN (DOCTYPE, entity declarations, undefined
/// entities), XML_TOO_DEEP and XML_MALFORMED (anything else, also non-UTF-8 and oversized input).
[[nodiscard]] doc_ptr parse_document(std::string_view data, const xml_limits& limits = {});

/// XML content (zero or more elements, OA-MSG-10) parsed inside a wrapper element.
struct fragment {
    doc_ptr doc;
    std::vector<xmlNode*> elements;  ///< the top-level elements, in order
};

/// Parse XML content; white space between the elements is ignored (OA-MSG-17), other text at
/// the top level is XML_MALFORMED. The depth limit counts from the first content element.
[[nodiscard]] fragment parse_fragment(std::string_view text, const xml_limits& limits = {});

/// Parse `<x>` + text + `</x>` and return the document (its root is the wrapper).
[[nodiscard]] doc_ptr parse_wrapped(std::string_view text, const xml_limits& limits = {});

// -- reading ---------------------------------------------------------------------------------

inline bool is_element(const xmlNode* n) noexcept {
    return n->type == XML_ELEMENT_NODE;
}
inline bool is_text(const xmlNode* n) noexcept {
    return n->type == XML_TEXT_NODE || n->type == XML_CDATA_SECTION_NODE;
}
inline std::string_view node_name(const xmlNode* n) noexcept {
    return n->name ? std::string_view(reinterpret_cast<const char*>(n->name)) : std::string_view();
}
inline std::string_view node_content(const xmlNode* n) noexcept {
    return n->content ? std::string_view(reinterpret_cast<const char*>(n->content))
                      : std::string_view();
}

/// ASCII lower case (OA-MSG-3: names compare in any case; other characters exactly).
[[nodiscard]] std::string ascii_lower(std::string_view text);
/// The lower-cased local name of an element or attribute.
[[nodiscard]] std::string local_name(const xmlNode* n);
/// Whether `text` is empty or XML white space only (space, TAB, CR, LF).
[[nodiscard]] bool is_blank(std::string_view text) noexcept;
/// `text` without surrounding XML white space.
[[nodiscard]] std::string_view strip_ws(std::string_view text) noexcept;

/// The child elements of `n` (comments and processing instructions skipped).
[[nodiscard]] std::vector<xmlNode*> child_elements(const xmlNode* n);
/// The value of an attribute.
[[nodiscard]] std::string attr_value(const xmlAttr* a);
/// The attribute `name` of `n`, its name matched in any case (OA-MSG-3), or nullopt.
[[nodiscard]] std::optional<std::string> attr(const xmlNode* n, std::string_view name);

/// One run of text between the nodes of an element (lxml's `text` and `tail`), or a node.
struct child_item {
    const xmlNode* node = nullptr;  ///< null for a text run
    std::string text;               ///< the run's text when `node` is null
};
/// The children of `n` as text runs and nodes, in document order.
[[nodiscard]] std::vector<child_item> child_items(const xmlNode* n);

/// The text of `n` with comments and processing instructions skipped; nullopt when `n` holds
/// an element (`*offender` then names it).
[[nodiscard]] std::optional<std::string> text_only(const xmlNode* n,
                                                   const xmlNode** offender = nullptr);
/// The text of `n` and all its descendants.
[[nodiscard]] std::string inner_text(const xmlNode* n);

/// Serialize an element (without what follows it) as lxml does: attributes in document order,
/// `<x/>` for empty elements, the escaping of spec/vectors/messages/README.md.
[[nodiscard]] std::string serialize(const xmlNode* n);
/// Serialize the inside of `n`: its elements, and text other than white space (escaped);
/// comments and processing instructions at this level are dropped.
[[nodiscard]] std::string inner_mixed(const xmlNode* n);
/// Serialize every child of `n` as it is (text runs escaped, comments and PIs kept).
[[nodiscard]] std::string inner_all(const xmlNode* n);

// -- writing ---------------------------------------------------------------------------------

/// Append `text` escaped as element text (`&amp; &lt; &gt;`, CR as `&#13;`). Throws API_MISUSE
/// for bytes that are not UTF-8 or characters XML 1.0 does not allow (OA-MSG-14); `what` names
/// the field in the error.
void escape_text(std::string& out, std::string_view text, std::string_view what);
/// Append `text` escaped as an attribute value (also `&quot;`, TAB/LF/CR as references).
void escape_attr(std::string& out, std::string_view text, std::string_view what);
/// Whether `name` is an XML name usable as an element name (no namespace prefix handling).
[[nodiscard]] bool is_xml_name(std::string_view name);

/// A small element writer: `open`, `attribute`s, then `text`/children, then `close`.
class xml_writer {
public:
    explicit xml_writer(std::string& out) : out_(out) {}
    void open(std::string_view name);
    void attribute(std::string_view name, std::string_view value, std::string_view what = "");
    void text(std::string_view value, std::string_view what = "");
    void raw(std::string_view xml);  ///< already serialized XML (from `serialize`)
    void close();
    /// `<name>text</name>`, or `<name/>` when text is empty.
    void text_element(std::string_view name, std::string_view value, std::string_view what = "");

private:
    void finish_start();
    std::string& out_;
    std::vector<std::string> open_;
    bool start_open_ = false;
};

}  // namespace openair::detail
