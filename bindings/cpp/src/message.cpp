// Message values: ids, replies, helpers (spec section 3).
#include "openair/message.hpp"

#include <cstdio>
#include <random>

#include "openair/error.hpp"
#include "xml.hpp"

namespace openair {

air_time air_time::from_ns(std::int64_t ns, bool with_usec) noexcept {
    std::int64_t sec = ns / 1000000000;
    std::int64_t rest = ns % 1000000000;
    if (rest < 0) {  // floor division, as for times before the epoch
        rest += 1000000000;
        sec -= 1;
    }
    air_time t;
    t.sec = sec;
    t.msec = static_cast<int>(rest / 1000000);
    if (with_usec) t.usec = static_cast<int>((rest / 1000) % 1000);
    return t;
}

std::vector<std::string> message::cc_names() const {
    std::vector<std::string> out;
    std::size_t start = 0;
    while (start <= cc.size()) {
        std::size_t end = cc.find(';', start);
        if (end == std::string::npos) end = cc.size();
        std::string_view name = detail::strip_ws(std::string_view(cc).substr(start, end - start));
        if (!name.empty()) out.emplace_back(name);  // OA-CC-1: empty names are skipped
        start = end + 1;
    }
    return out;
}

const slot* message::extra(const std::string& name) const noexcept {
    std::string wanted = detail::ascii_lower(name);
    for (const slot& s : extras) {
        if (detail::ascii_lower(s.name) == wanted) return &s;
    }
    return nullptr;
}

void message::set_extra(const std::string& name, const std::string& value, bool is_xml) {
    std::string wanted = detail::ascii_lower(name);
    std::vector<slot> kept;
    for (slot& s : extras) {
        if (detail::ascii_lower(s.name) != wanted) kept.push_back(std::move(s));
    }
    kept.push_back(slot{name, value, is_xml});
    extras = std::move(kept);
}

message message::reply(const std::string& reply_type, const std::string& from,
                       const std::string& reply_content) const {
    message r = make_message(reply_type, from, sender);
    r.isresponse = id;  // OA-SESS-1
    r.content = reply_content;
    return r;
}

bool operator==(const message& a, const message& b) {
    return a.type == b.type && a.id == b.id && a.sender == b.sender && a.to == b.to &&
           a.cc == b.cc && a.stored == b.stored && a.isresponse == b.isresponse &&
           a.inreplyto == b.inreplyto && a.posted == b.posted && a.received == b.received &&
           a.priority == b.priority && a.timetolive == b.timetolive && a.noreply == b.noreply &&
           a.language == b.language && a.content == b.content &&
           a.content_is_xml == b.content_is_xml && a.comment == b.comment &&
           a.history == b.history && a.wbid == b.wbid && a.netprotocol == b.netprotocol &&
           a.extras == b.extras && a.binary == b.binary;
}

std::string new_id() {
    thread_local std::mt19937_64 gen{[] {
        std::random_device rd;
        std::seed_seq seq{rd(), rd(), rd(), rd()};
        return std::mt19937_64(seq);
    }()};
    std::uint64_t hi = gen();
    std::uint64_t lo = gen();
    hi = (hi & 0xFFFFFFFFFFFF0FFFull) | 0x0000000000004000ull;  // version 4
    lo = (lo & 0x3FFFFFFFFFFFFFFFull) | 0x8000000000000000ull;  // RFC 4122 variant
    char text[40];
    std::snprintf(text, sizeof text, "%08x-%04x-%04x-%04x-%012llx", static_cast<unsigned>(hi >> 32),
                  static_cast<unsigned>((hi >> 16) & 0xFFFF), static_cast<unsigned>(hi & 0xFFFF),
                  static_cast<unsigned>(lo >> 48),
                  static_cast<unsigned long long>(lo & 0xFFFFFFFFFFFFull));
    return text;
}

message make_message(const std::string& type, const std::string& from, const std::string& to) {
    message m;
    m.type = type;
    m.id = new_id();
    m.sender = from;
    m.to = to;
    return m;
}

error::error(errc code, const std::string& detail)
    : std::runtime_error(detail.empty() ? std::string(errc_name(code))
                                        : std::string(errc_name(code)) + ": " + detail),
      code_(code),
      detail_(detail) {}

}  // namespace openair
