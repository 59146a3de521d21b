// Writing messages in the canonical form of spec 3.5, byte for byte as
// spec/vectors/messages/README.md describes it.
#include <cmath>
#include <cstdio>
#include <set>

#include "codec_internal.hpp"
#include "numbers.hpp"
#include "openair/codec.hpp"
#include "test_faults.hpp"
#include "xml.hpp"

namespace openair {

namespace detail {
namespace {

[[noreturn]] void misuse(const std::string& detail) {
    throw error(errc::api_misuse, detail);
}

std::string decimal_attribute(double value, const char* what) {
    if (!std::isfinite(value)) misuse(std::string(what) + " must be a finite number");
    return format_decimal(value);
}

/// Copy caller-supplied inner XML (elements and text) through the hardened parser, so that
/// what is written is well-formed XML and never blind concatenation (OA-MSG-10).
std::string graft(std::string_view xml, std::string_view where) {
    try {
        doc_ptr doc = parse_wrapped(xml);
        return inner_all(xmlDocGetRootElement(doc.get()));
    } catch (const error& e) {
        misuse(std::string(where) + " is not well-formed inner XML: " + e.what());
    }
}

void write_reference(xml_writer& w, const reference& ref) {
    w.open("inreplyto");
    w.open("reference");
    w.attribute("id", ref.id, "inreplyto id");
    const std::pair<const char*, const std::string*> optional_attrs[] = {{"type", &ref.type},
                                                                         {"from", &ref.sender},
                                                                         {"to", &ref.to},
                                                                         {"cc", &ref.cc},
                                                                         {"stored", &ref.stored}};
    for (const auto& [name, value] : optional_attrs) {
        if (!value->empty()) w.attribute(name, *value, std::string("inreplyto ") + name);
    }
    if (ref.time) {  // schemas/message.xsd ReferenceType has no usec
        w.attribute("sec", std::to_string(ref.time->sec));
        w.attribute("msec", std::to_string(ref.time->msec));
    }
    w.close();
    w.close();
}

/// The optional slots between isresponse and content, in canonical order (spec 3.5).
void write_middle(xml_writer& w, const message& msg, const std::vector<std::uint64_t>* sizes) {
    if (msg.inreplyto) write_reference(w, *msg.inreplyto);
    // A message received without postedTime cannot be given one here (OA-TIME-4).
    if (msg.posted) {
        // Test-only fault (openair-shim-broken): the legacy spelling, never canonical.
        write_time(w, OPENAIR_FAULT(lowercase_postedtime) ? "postedtime" : "postedTime",
                   *msg.posted);
    }
    if (msg.received) write_time(w, "receivedTime", *msg.received);
    if (!msg.comment.empty()) w.text_element("comment", msg.comment);
    if (!msg.history.empty()) {
        w.open("history");
        w.raw(graft(msg.history, "history"));
        w.close();
    }
    if (msg.wbid) {
        char digits[32];
        std::snprintf(digits, sizeof digits, "%08llu", static_cast<unsigned long long>(*msg.wbid));
        w.text_element("wbid", digits);  // OA-MSG-13: at least 8 digits
    }
    if (!msg.netprotocol.empty()) w.text_element("netprotocol", msg.netprotocol);
    std::vector<std::uint64_t> own;
    if (sizes == nullptr) {
        for (const std::string& chunk : msg.binary) own.push_back(chunk.size());
        sizes = &own;
    }
    if (!sizes->empty()) {  // OA-FRAME-4
        std::string list;
        std::uint64_t total = 0;
        for (std::uint64_t size : *sizes) {
            if (!list.empty()) list += ',';
            list += std::to_string(size);
            total += size;
        }
        w.text_element("binarysizes", list);
        w.text_element("totalbinarysize", std::to_string(total));
    }
}

/// Write `content`, always present (OA-MSG-4); XML content unescaped (OA-MSG-10).
void write_content(xml_writer& w, const message& msg) {
    bool xml_language = ascii_lower(msg.language) == "xml";
    w.open("content");
    if (msg.content_is_xml) {
        w.attribute("language", xml_language ? msg.language : std::string("xml"), "language");
        if (!msg.content.empty()) w.raw(graft(msg.content, "content"));
    } else {
        if (xml_language) misuse("text content cannot be labelled language='" + msg.language + "'");
        w.attribute("language", msg.language, "language");
        w.text(msg.content, "content");
    }
    w.close();
}

bool is_known_slot(const std::string& lowered) {
    static const std::set<std::string> known = {"type",
                                                "id",
                                                "from",
                                                "to",
                                                "cc",
                                                "stored",
                                                "isresponse",
                                                "comment",
                                                "netprotocol",
                                                "inreplyto",
                                                "postedtime",
                                                "receivedtime",
                                                "history",
                                                "wbid",
                                                "content",
                                                "binarysizes",
                                                "totalbinarysize"};
    return known.count(lowered) != 0;
}

/// Write an unknown slot under its own name (OA-MSG-5).
void write_extra(xml_writer& w, const slot& s) {
    if (is_known_slot(ascii_lower(s.name))) {
        misuse("extension slot '" + s.name + "' has the name of a known slot");
    }
    if (!is_xml_name(s.name)) misuse("extension slot name '" + s.name + "' is not an XML name");
    w.open(s.name);
    if (s.is_xml) {
        w.raw(graft(s.value, "extension slot '" + s.name + "'"));
    } else {
        w.text(s.value, "slot '" + s.name + "'");
    }
    w.close();
}

}  // namespace

void write_time(xml_writer& w, std::string_view name, const air_time& t) {
    if (t.msec < 0 || t.msec > 999 || (t.usec && (*t.usec < 0 || *t.usec > 999))) {
        misuse(std::string(name) + ": msec and usec must be 0-999");  // OA-TIME-1
    }
    w.open(name);
    w.attribute("sec", std::to_string(t.sec));
    w.attribute("msec", std::to_string(t.msec));
    if (t.usec) w.attribute("usec", std::to_string(*t.usec));  // OA-TIME-5
    w.close();
}

void write_message(std::string& out, const message& msg,
                   const std::vector<std::uint64_t>* chunk_sizes) {
    if (msg.type.empty()) misuse("a message needs a non-empty type");  // OA-MSG-2
    xml_writer w(out);
    w.open("message");
    if (msg.priority) {
        std::string text = decimal_attribute(*msg.priority, "priority");
        if (!(*msg.priority >= 0.0 && *msg.priority <= 6.999)) {  // OA-MSG-6
            misuse("priority " + text + " is outside 0.0-6.999");
        }
        w.attribute("priority", text);
    }
    if (msg.timetolive) w.attribute("timetolive", decimal_attribute(*msg.timetolive, "timetolive"));
    if (msg.noreply) w.attribute("noreply", "yes");  // OA-MSG-15
    w.text_element("type", msg.type);
    w.text_element("id", msg.id);
    w.text_element("from", msg.sender);
    w.text_element("to", msg.to);
    w.text_element("cc", msg.cc);
    w.text_element("stored", msg.stored);
    w.text_element("isresponse", msg.isresponse);
    write_middle(w, msg, chunk_sizes);
    write_content(w, msg);
    for (const slot& s : msg.extras) write_extra(w, s);
    w.close();
}

}  // namespace detail

std::string encode_message(const message& msg) {
    std::string out;
    detail::write_message(out, msg);
    return out;
}

frame to_frame(const message& msg, frame_tag tag) {
    if (tag == frame_tag::binary) {
        throw error(errc::api_misuse,
                    "a message travels in a Message or Receive frame, not BinaryM");
    }
    return frame{tag, encode_message(msg), msg.binary};
}

}  // namespace openair
