// Reading messages (spec 3, 4): every legacy spelling accepted, bad values refused.
#include <map>
#include <set>
#include <utility>

#include "codec_internal.hpp"
#include "numbers.hpp"
#include "openair/codec.hpp"
#include "xml.hpp"

namespace openair {

namespace detail {
namespace {

[[noreturn]] void invalid(const std::string& detail) {
    throw error(errc::message_invalid, detail);
}

std::string clip(std::string_view text, std::size_t limit = 40) {
    std::string_view s = strip_ws(text);
    return s.size() <= limit ? std::string(s) : std::string(s.substr(0, limit)) + "...";
}

/// Refuse non-whitespace text between elements (only indentation may sit there).
void no_text(const std::string& text, std::string_view where) {
    if (!is_blank(text)) {
        invalid("text '" + clip(text) + "' between the elements of <" + std::string(where) + ">");
    }
}

/// The text of a text slot; an element inside is MESSAGE_INVALID (OA-MSG-9).
std::string slot_text(const xmlNode* el) {
    const xmlNode* offender = nullptr;
    auto text = text_only(el, &offender);
    if (!text) {
        invalid("slot <" + std::string(node_name(el)) + "> must be text, found <" +
                std::string(node_name(offender)) + ">");
    }
    return *text;
}

/// A time from lower-cased attributes; any bad value is MESSAGE_INVALID (OA-TIME-1, OA-TIME-6).
air_time time_from_attributes(const std::map<std::string, std::string>& attrs,
                              std::string_view where) {
    std::string w(where);
    auto sec_it = attrs.find("sec");
    if (sec_it == attrs.end()) invalid("<" + w + "> has no sec attribute");
    auto sec = parse_int64(sec_it->second, true);  // OA-TIME-1: signed 64-bit
    if (!sec)
        invalid("sec of <" + w + "> is not a 64-bit decimal integer: '" + clip(sec_it->second) +
                "'");
    air_time t;
    t.sec = *sec;
    auto below_1000 = [&w](const std::string& text, const char* what) {
        auto v = parse_int64(text, false);
        if (!v || *v > 999) {  // OA-TIME-6
            invalid(std::string(what) + " of <" + w + "> must be 0-999, got '" + clip(text) + "'");
        }
        return static_cast<int>(*v);
    };
    auto msec_it = attrs.find("msec");
    if (msec_it == attrs.end()) msec_it = attrs.find("ms");  // OA-TIME-1: msec wins over ms
    if (msec_it != attrs.end()) t.msec = below_1000(msec_it->second, "msec");
    auto usec_it = attrs.find("usec");  // OA-TIME-5
    if (usec_it != attrs.end()) t.usec = below_1000(usec_it->second, "usec");
    return t;
}

reference read_reference(const xmlNode* el) {
    auto attrs = attributes(el);
    reference ref;
    if (attrs.count("sec") || attrs.count("msec") || attrs.count("ms")) {
        ref.time = time_from_attributes(attrs, "reference");
    } else {
        for (const xmlNode* child : child_elements(el)) {
            // Psyclone writes the time of a reference as a postedTime child.
            if (local_name(child) == "postedtime") ref.time = read_time(child);
        }
    }
    auto get = [&attrs](const char* name) {
        auto it = attrs.find(name);
        return it == attrs.end() ? std::string() : it->second;
    };
    ref.id = get("id");
    ref.stored = get("stored");
    ref.type = get("type");
    ref.sender = get("from");
    ref.to = get("to");
    ref.cc = get("cc");
    return ref;
}

/// Read the one `<reference>` of `inreplyto` (OA-MSG-11).
reference read_inreplyto(const xmlNode* el) {
    std::vector<const xmlNode*> refs;
    for (const child_item& item : child_items(el)) {
        if (item.node == nullptr) {
            no_text(item.text, "inreplyto");
        } else if (is_element(item.node)) {
            if (local_name(item.node) != "reference") {
                invalid("inreplyto holds <" + std::string(node_name(item.node)) +
                        ">, not <reference>");
            }
            refs.push_back(item.node);
        }
    }
    if (refs.size() != 1) {  // OA-MSG-11
        invalid("inreplyto must hold one reference, found " + std::to_string(refs.size()));
    }
    return read_reference(refs.front());
}

/// Serialize the child elements of `history`; whitespace between them is dropped (OA-MSG-17).
std::string read_history(const xmlNode* el) {
    std::string out;
    for (const child_item& item : child_items(el)) {
        if (item.node == nullptr) {
            no_text(item.text, "history");
        } else if (is_element(item.node)) {
            out += serialize(item.node);
        }
    }
    return out;
}

void read_root_attributes(const xmlNode* root, message& m, bool clamp_priority) {
    auto attrs = attributes(root);
    if (auto it = attrs.find("priority"); it != attrs.end()) {
        auto value = parse_decimal(it->second);
        if (!value) invalid("priority is not a decimal number: '" + clip(it->second) + "'");
        if (!(*value >= 0.0 && *value <= 6.999)) {
            // OA-MSG-19: a client reads a legacy peer's 7.00 as 6.999; a server refuses a
            // post out of range (OA-MSG-6).
            if (!clamp_priority) {
                invalid("priority '" + clip(it->second) + "' is outside 0.0-6.999");
            }
            *value = *value < 0.0 ? 0.0 : 6.999;
        }
        m.priority = *value;
    }
    if (auto it = attrs.find("timetolive"); it != attrs.end()) {
        auto value = parse_decimal(it->second);  // OA-MSG-7: carried, no effect
        if (!value) invalid("timetolive is not a decimal number: '" + clip(it->second) + "'");
        m.timetolive = *value;
    }
    if (auto it = attrs.find("noreply"); it != attrs.end()) {
        std::string flag = ascii_lower(strip_ws(it->second));
        if (flag != "yes" && flag != "no") {  // OA-MSG-15: yes or no, any case
            invalid("noreply must be yes or no, got '" + clip(it->second) + "'");
        }
        m.noreply = flag == "yes";
    }
}

void read_content(const xmlNode* el, message& m) {
    auto attrs = attributes(el);
    auto it = attrs.find("language");
    m.language = it == attrs.end() ? std::string() : it->second;
    if (ascii_lower(m.language) == "xml") {
        // Stray text is kept, not refused: the command that reads the content judges it
        // (OA-MSG-18), and a relay passes it on.
        m.content = inner_mixed(el);
        m.content_is_xml = true;
    } else {
        m.content = slot_text(el);  // OA-MSG-10
    }
}

/// Keep an unknown slot (OA-MSG-5): its text, or its inner XML when it holds elements.
slot read_extra(const xmlNode* el) {
    slot s;
    s.name = std::string(node_name(el));
    if (!child_elements(el).empty()) {
        s.value = inner_mixed(el);
        s.is_xml = true;
    } else {
        s.value = slot_text(el);
    }
    return s;
}

/// Read one known or unknown slot into `m`; returns false when `name` is no known slot.
bool read_known(const std::string& name, const xmlNode* child, message& m) {
    static const std::map<std::string, std::string message::*> text_slots = {
        {"type", &message::type},
        {"id", &message::id},
        {"from", &message::sender},
        {"to", &message::to},
        {"cc", &message::cc},
        {"stored", &message::stored},
        {"isresponse", &message::isresponse},
        {"comment", &message::comment},
        {"netprotocol", &message::netprotocol}};
    if (auto it = text_slots.find(name); it != text_slots.end()) {
        m.*(it->second) = slot_text(child);
    } else if (name == "inreplyto") {
        m.inreplyto = read_inreplyto(child);
    } else if (name == "postedtime") {
        m.posted = read_time(child);
    } else if (name == "receivedtime") {
        m.received = read_time(child);
    } else if (name == "history") {
        m.history = read_history(child);
    } else if (name == "wbid") {
        std::string text = slot_text(child);
        auto value = parse_uint64(text);  // OA-MSG-13: a non-negative decimal integer
        if (!value) invalid("wbid must be a non-negative integer, got '" + clip(text) + "'");
        m.wbid = *value;
    } else if (name == "content") {
        read_content(child, m);
    } else {
        return false;
    }
    return true;
}

}  // namespace

std::map<std::string, std::string> attributes(const xmlNode* el) {
    std::map<std::string, std::string> out;
    for (const xmlAttr* a = el->properties; a != nullptr; a = a->next) {
        std::string name = ascii_lower(reinterpret_cast<const char*>(a->name));
        if (!out.emplace(name, attr_value(a)).second) {  // the same attribute in two spellings
            invalid("attribute '" + name + "' given twice on <" + std::string(node_name(el)) + ">");
        }
    }
    return out;
}

air_time read_time(const xmlNode* el) {
    return time_from_attributes(attributes(el), node_name(el));
}

message decode_element(const xmlNode* root, std::vector<std::string> chunks,
                       bool clamp_priority) {
    message m;
    m.binary = std::move(chunks);
    read_root_attributes(root, m, clamp_priority);
    std::set<std::string> seen;
    for (const child_item& item : child_items(root)) {
        if (item.node == nullptr) {
            no_text(item.text, "message");
            continue;
        }
        if (!is_element(item.node)) continue;  // a comment or processing instruction
        std::string name = local_name(item.node);
        if (seen.count(name)) {  // OA-MSG-16
            invalid("slot <" + std::string(node_name(item.node)) + "> occurs more than once");
        }
        if (read_known(name, item.node, m)) {
            seen.insert(name);
            continue;
        }
        bool derived = name == "binarysizes" || name == "totalbinarysize";  // from the chunks
        if (derived || name == "extensions") seen.insert(name);   // defined, so at most once
        if (!derived) m.extras.push_back(read_extra(item.node));  // OA-MSG-5
    }
    if (m.type.empty()) invalid("the type slot is missing or empty");  // OA-MSG-2
    return m;
}

}  // namespace detail

message decode_message(std::string_view xml, std::vector<std::string> chunks,
                       const xml_limits& limits, bool clamp_priority) {
    detail::doc_ptr doc = detail::parse_document(xml, limits);  // OA-MSG-1, OA-SEC-1/2
    const xmlNode* root = xmlDocGetRootElement(doc.get());
    if (detail::local_name(root) != "message") {  // OA-MSG-1
        throw error(
            errc::xml_malformed,
            "root element is <" + std::string(detail::node_name(root)) + ">, not <message>");
    }
    return detail::decode_element(root, std::move(chunks), clamp_priority);
}

message from_frame(const frame& f, const xml_limits& limits, bool clamp_priority) {
    if (f.tag == frame_tag::binary) {
        throw error(errc::message_invalid, "a BinaryM frame carries no message");  // OA-FRAME-5
    }
    return decode_message(f.xml, f.chunks, limits, clamp_priority);
}

std::optional<message> find_message(std::string_view xml_content) {
    detail::fragment frag = detail::parse_fragment(xml_content);
    for (const xmlNode* top : frag.elements) {
        std::vector<const xmlNode*> stack{top};
        while (!stack.empty()) {
            const xmlNode* n = stack.back();
            stack.pop_back();
            if (detail::local_name(n) == "message") return detail::decode_element(n, {});
            for (const xmlNode* c = n->last; c != nullptr; c = c->prev) {
                if (detail::is_element(c)) stack.push_back(c);
            }
        }
    }
    return std::nullopt;
}

}  // namespace openair
