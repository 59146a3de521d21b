// The OpenAIR message envelope as plain values (spec sections 3 and 4). No XML here: codec.hpp
// reads and writes these values.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace openair {

/// A point in time as OpenAIR carries it (spec 4): Unix seconds, milliseconds and, under the
/// `usec` extension, microseconds within the millisecond (OA-TIME-1, OA-TIME-5).
struct air_time {
    std::int64_t sec = 0;
    int msec = 0;             ///< 0-999
    std::optional<int> usec;  ///< 0-999, only under the `usec` extension

    /// Build a time from nanoseconds since the epoch (what `std::chrono::system_clock` gives).
    [[nodiscard]] static air_time from_ns(std::int64_t ns, bool with_usec = false) noexcept;
    /// Milliseconds since the epoch (microseconds dropped).
    [[nodiscard]] std::int64_t ms() const noexcept { return sec * 1000 + msec; }

    friend bool operator==(const air_time& a, const air_time& b) noexcept {
        return a.sec == b.sec && a.msec == b.msec && a.usec == b.usec;
    }
    friend bool operator!=(const air_time& a, const air_time& b) noexcept { return !(a == b); }
};

/// A `<reference>` to another message (the `inreplyto` slot, OA-MSG-11).
struct reference {
    std::string id;
    std::string stored;
    std::string type;
    std::string sender;  ///< the `from` attribute
    std::string to;
    std::string cc;
    std::optional<air_time> time;

    friend bool operator==(const reference& a, const reference& b) {
        return a.id == b.id && a.stored == b.stored && a.type == b.type && a.sender == b.sender &&
               a.to == b.to && a.cc == b.cc && a.time == b.time;
    }
};

/// An unknown slot, kept verbatim (OA-MSG-5): its name and its text or inner XML.
struct slot {
    std::string name;
    std::string value;
    bool is_xml = false;

    friend bool operator==(const slot& a, const slot& b) {
        return a.name == b.name && a.value == b.value && a.is_xml == b.is_xml;
    }
};

/// One OpenAIR message. Strings are UTF-8; binary chunks are raw bytes held in std::string.
///
/// `content` is text unless `content_is_xml`, in which case it is the inner XML of `<content>`
/// (zero or more elements, OA-MSG-10). An absent `priority` means 2.0 (OA-MSG-6). `binary`
/// holds the chunks sent after the XML; the codec writes `binarysizes` from them (OA-FRAME-4).
struct message {
    std::string type;
    std::string id;
    std::string sender;  ///< the `from` slot
    std::string to;
    std::string cc;
    std::string stored;
    std::string isresponse;
    std::optional<reference> inreplyto;
    std::optional<air_time> posted;
    std::optional<air_time> received;
    std::optional<double> priority;
    std::optional<double> timetolive;
    bool noreply = false;
    std::string language;
    std::string content;
    bool content_is_xml = false;
    std::string comment;
    std::string history;  ///< raw inner XML of the `history` slot
    std::optional<std::uint64_t> wbid;
    std::string netprotocol;
    std::vector<slot> extras;
    std::vector<std::string> binary;

    /// The priority used for ordering: the slot's value, or 2.0 when absent (OA-PRIO-3).
    [[nodiscard]] double effective_priority() const noexcept { return priority ? *priority : 2.0; }
    /// The module names in `cc`: split at `;`, white space around names ignored (OA-CC-1).
    [[nodiscard]] std::vector<std::string> cc_names() const;
    /// The unknown slot called `name` (ASCII case-insensitive, OA-MSG-3), if any.
    [[nodiscard]] const slot* extra(const std::string& name) const noexcept;
    /// Set the unknown slot `name`, replacing one of the same name (any case).
    void set_extra(const std::string& name, const std::string& value, bool is_xml = false);
    /// Build a reply to this request: `isresponse` = this id, addressed to the sender (OA-SESS-1).
    [[nodiscard]] message reply(const std::string& reply_type, const std::string& from,
                                const std::string& reply_content = "") const;

    friend bool operator==(const message& a, const message& b);
    friend bool operator!=(const message& a, const message& b) { return !(a == b); }
};

/// A fresh random UUID (version 4) string for a message id (OA-MSG-8).
[[nodiscard]] std::string new_id();

/// Build a message with a fresh id.
[[nodiscard]] message make_message(const std::string& type, const std::string& from = "",
                                   const std::string& to = "");

}  // namespace openair
