// Registrations, retrieve specifications, capabilities and retrieve results (spec 8, 9, 15).
#include "openair/content.hpp"

#include "codec_internal.hpp"
#include "numbers.hpp"
#include "openair/error.hpp"
#include "openair/types.hpp"
#include "test_faults.hpp"
#include "xml.hpp"

namespace openair {

namespace {

void write_trigger(detail::xml_writer& w, const trigger& t) {
    validate_pattern(t.type);  // OA-MATCH-7: refuse before the server has to
    w.open("trigger");
    w.attribute("type", t.type);
    if (!t.from.empty()) w.attribute("from", t.from);
    if (t.after_ms != 0) w.attribute("after", std::to_string(t.after_ms));
    if (!t.alias.empty()) w.attribute("alias", t.alias);
    w.close();
}

/// A time bound: epoch milliseconds as text, or a `<time>` child when ms cannot say it all.
void write_bound(detail::xml_writer& w, const char* name, const air_time& t) {
    w.open(name);
    if (!t.usec) {
        w.text(std::to_string(t.ms()));  // the form Psyclone's own writer uses
    } else {
        detail::write_time(w, "time", t);
    }
    w.close();
}

void write_retrieve(detail::xml_writer& w, const retrieve_spec& spec) {
    if (!spec.type.empty()) validate_pattern(spec.type);
    w.open("retrieve");
    const std::pair<const char*, const std::string*> attrs[] = {{"from", &spec.whiteboard},
                                                                {"type", &spec.type},
                                                                {"id", &spec.id},
                                                                {"sender", &spec.sender},
                                                                {"content", &spec.content}};
    for (const auto& [name, value] : attrs) {
        if (!value->empty()) w.attribute(name, *value);
    }
    if (spec.content_match_xml) w.attribute("contentmatch", "xml");
    w.text_element("latest", std::to_string(spec.latest));
    if (spec.lastmsec) w.text_element("lastmsec", std::to_string(*spec.lastmsec));
    if (spec.after_time) write_bound(w, "afterTime", *spec.after_time);
    if (spec.until_time) write_bound(w, "untilTime", *spec.until_time);
    w.close();
}

/// Parse content as exactly one element called `name`, else CONTENT_INVALID.
const xmlNode* single_root(const detail::fragment& frag, std::string_view name) {
    if (frag.elements.size() != 1 || detail::local_name(frag.elements.front()) != name) {
        std::string found;
        for (const xmlNode* el : frag.elements) found += "<" + detail::local_name(el) + ">";
        throw error(errc::content_invalid, "content must be one <" + std::string(name) +
                                               ">, found " +
                                               (found.empty() ? "no element" : found));
    }
    return frag.elements.front();
}

detail::fragment parse_content(std::string_view content) {
    try {
        return detail::parse_fragment(content);
    } catch (const error& e) {
        throw error(errc::content_invalid, "content is not well-formed XML: " + e.detail());
    }
}

}  // namespace

bool capabilities::has_extension(std::string_view name) const {
    for (const std::string& e : extensions) {
        if (e == name) return true;
    }
    return false;
}

std::optional<std::uint64_t> capabilities::limit(std::string_view name) const {
    for (const auto& [key, value] : limits) {
        if (key == name) return value;
    }
    return std::nullopt;
}

std::string encode_registration(const std::string& module, const std::vector<trigger>& triggers,
                                const std::vector<retrieve_spec>& retrieves,
                                bool allow_self_triggering,
                                const std::vector<std::string>& streams) {
    std::string out;
    detail::xml_writer w(out);
    w.open("module");
    w.attribute("name", module);
    if (allow_self_triggering) w.attribute("allowselftriggering", "yes");  // OA-REG-6
    if (!triggers.empty()) {
        w.open("triggers");
        for (const trigger& t : triggers) write_trigger(w, t);
        w.close();
    }
    if (!retrieves.empty()) {  // a <retrieves> group holds at least one retrieve
        w.open("retrieves");
        for (const retrieve_spec& r : retrieves) write_retrieve(w, r);
        w.close();
    }
    for (const std::string& source : streams) {  // OA-STREAM-14
        if (source.empty()) throw error(errc::api_misuse, "an input stream needs a source");
        w.open("inputstream");
        w.attribute("alias", source, "input stream");
        w.attribute("source", source, "input stream");
        w.close();
    }
    w.close();
    return out;
}

std::string encode_retrieve(const retrieve_spec& spec) {
    std::string out;
    detail::xml_writer w(out);
    write_retrieve(w, spec);
    return out;
}

std::string encode_retrieves(const std::vector<retrieve_spec>& specs) {
    if (specs.empty())
        throw error(errc::api_misuse, "encode_retrieves needs at least one retrieve");
    std::string out;
    detail::xml_writer w(out);
    w.open("retrieves");
    for (const retrieve_spec& r : specs) write_retrieve(w, r);
    w.close();
    return out;
}

capabilities parse_capabilities(std::string_view content) {
    detail::fragment frag = parse_content(content);
    const xmlNode* root = single_root(frag, "capabilities");
    capabilities caps;
    auto protocol = detail::attr(root, "protocol");
    auto server = detail::attr(root, "server");
    if (!protocol || protocol->empty()) {
        throw error(errc::content_invalid, "capabilities without a protocol");  // OA-CAP-1
    }
    if (!server) throw error(errc::content_invalid, "capabilities without a server");  // OA-CAP-1
    caps.protocol = *protocol;
    caps.server = *server;
    for (const xmlNode* child : detail::child_elements(root)) {
        std::string kind = detail::local_name(child);
        if (kind != "extension" && kind != "limit") continue;  // OA-CAP-3: ignore the unknown
        auto name = detail::attr(child, "name");
        if (!name || name->empty())
            throw error(errc::content_invalid, "<" + kind + "> without a name");
        if (kind == "extension") {
            if (!caps.has_extension(*name)) caps.extensions.push_back(*name);
            continue;
        }
        auto value = detail::parse_uint64(detail::attr(child, "value").value_or(""));
        if (!value) {
            throw error(errc::content_invalid,
                        "limit '" + *name + "' has no non-negative integer value");
        }
        if (!caps.limit(*name)) caps.limits.emplace_back(*name, *value);
    }
    return caps;
}

namespace detail {

std::vector<std::string> chunk_cursor::take(const xmlNode* el) {
    std::vector<std::string> out;
    for (const xmlNode* slot : child_elements(el)) {
        if (local_name(slot) != "binarysizes") continue;  // OA-MSG-3: any case
        std::string text = inner_text(slot);  // kept: the view below points into it
        std::string_view list = strip_ws(text);
        while (!list.empty()) {
            std::size_t comma = list.find(',');
            auto size = parse_uint64(list.substr(0, comma));
            if (!size) throw error(errc::content_invalid, "a nested binarysizes is not a list");
            if (next_ >= chunks_.size()) {  // OA-MSG-21
                throw error(errc::content_invalid, "fewer chunks than the nested messages list");
            }
            if (chunks_[next_].size() != *size) {
                throw error(errc::content_invalid, "a chunk's size differs from its binarysizes");
            }
            out.push_back(std::move(chunks_[next_++]));
            if (OPENAIR_FAULT(attachments_dropped)) out.pop_back();  // test-only fault
            if (comma == std::string_view::npos) break;
            list = list.substr(comma + 1);
        }
        break;
    }
    return out;
}

void chunk_cursor::finish() const {
    if (next_ != chunks_.size()) {  // OA-MSG-21: no chunk that no nested message lists
        throw error(errc::content_invalid, std::to_string(chunks_.size() - next_) +
                                               " chunk(s) that no nested message lists");
    }
}

/// Read the messages of an `<objectcollection>` element, one `<object>` each.
std::vector<message> read_message_collection(const xmlNode* root, chunk_cursor* cursor) {
    if (local_name(root) != "objectcollection") {
        throw error(errc::content_invalid,
                    "expected <objectcollection>, found <" + local_name(root) + ">");
    }
    std::vector<message> out;
    std::size_t index = 0;
    for (const xmlNode* obj : child_elements(root)) {
        std::string where = "object " + std::to_string(index++);
        if (local_name(obj) != "object") {
            throw error(errc::content_invalid,
                        "<objectcollection> holds <" + local_name(obj) + ">");
        }
        std::vector<xmlNode*> inner = child_elements(obj);
        if (inner.size() != 1 || local_name(inner.front()) != "message") {
            throw error(errc::content_invalid, where + " must hold exactly one <message>");
        }
        std::vector<std::string> chunks;
        if (cursor != nullptr) chunks = cursor->take(inner.front());  // OA-MSG-21
        try {
            out.push_back(decode_element(inner.front(), std::move(chunks)));
        } catch (const error& e) {
            throw error(errc::content_invalid, where + ": " + e.detail());
        }
    }
    return out;
}

}  // namespace detail

std::vector<message> parse_message_collection(std::string_view content,
                                              std::vector<std::string> chunks) {
    detail::chunk_cursor cursor(std::move(chunks));
    std::vector<message> out;
    if (!detail::is_blank(content)) {
        detail::fragment frag = parse_content(content);
        out = detail::read_message_collection(single_root(frag, "objectcollection"), &cursor);
    }
    cursor.finish();
    return out;
}

}  // namespace openair
