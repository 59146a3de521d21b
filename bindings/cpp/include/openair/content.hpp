// Content objects a client writes and reads (spec sections 8, 9, 15): registrations, retrieve
// specifications, capabilities, retrieve results and wakeups. Plain values; XML stays inside.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "openair/message.hpp"

namespace openair {

inline constexpr std::string_view wakeup_type = "AIR.Instruct.Wakeup";
inline constexpr std::string_view default_context = "Psyclone.System.Ready";

/// One `<trigger type from after alias/>` (spec 8.2, OA-TRIG-1..3). An empty `from` means
/// every whiteboard (OA-TRIG-2).
struct trigger {
    std::string type;  ///< a pattern (OA-MATCH-7)
    std::string from;
    std::uint64_t after_ms = 0;
    std::string alias;
};

/// One `<retrieve>` (spec 9.2). Empty strings and nullopt mean "criterion absent"; `latest`
/// defaults to 1 and 0 means no limit (OA-RET-4).
struct retrieve_spec {
    std::string whiteboard;  ///< `from`: the whiteboard to read (OA-RET-2)
    std::string type;        ///< a pattern
    std::string id;
    std::string sender;
    std::string content;  ///< a glob (OA-RET-8)
    bool content_match_xml = false;
    std::uint64_t latest = 1;
    std::optional<std::uint64_t> lastmsec;
    std::optional<air_time> after_time;
    std::optional<air_time> until_time;
};

/// A CAPABILITIES reply (spec 15.1). Names are kept as written; unknown ones are ignored by
/// whoever uses them (OA-CAP-3).
struct capabilities {
    std::string protocol;
    std::string server;
    std::vector<std::string> extensions;
    std::vector<std::pair<std::string, std::uint64_t>> limits;

    [[nodiscard]] bool has_extension(std::string_view name) const;
    [[nodiscard]] std::optional<std::uint64_t> limit(std::string_view name) const;
};

/// The `<phase>` of a wakeup's PhaseSpec (OA-WAKE-4), read leniently.
struct phase_spec {
    std::string name;
    std::string module;
    std::string context;
    std::string lasttrigger;
    std::vector<trigger> triggers;
};

/// An `AIR.Instruct.Wakeup` taken apart (spec 8.7, 8.8). `trigger` is nullopt for a phase
/// update (OA-WAKE-8); `phase` is nullopt when the wakeup carries no PhaseSpec. `lasttrigger`
/// is the pattern that fired, empty for a wakeup due only to `cc` (OA-WAKE-4).
struct wakeup {
    std::optional<message> trigger;
    std::vector<message> retrieved;
    std::optional<phase_spec> phase;
    std::string lasttrigger;
};

/// AIR.Subscribe content in the module form (OA-REG-3): `<module name [allowselftriggering]>`
/// holding `<triggers>` and `<retrieves>` groups. Throws PATTERN_INVALID for an invalid
/// pattern (OA-MATCH-7) and API_MISUSE for characters XML cannot carry.
/// `streams` adds one `<inputstream alias="S" source="S"/>` per name, type or type pattern S
/// (OA-STREAM-14).
[[nodiscard]] std::string encode_registration(const std::string& module,
                                              const std::vector<trigger>& triggers,
                                              const std::vector<retrieve_spec>& retrieves = {},
                                              bool allow_self_triggering = false,
                                              const std::vector<std::string>& streams = {});
/// One `<retrieve>` (AIR.Retrieve content); `latest` is always written.
[[nodiscard]] std::string encode_retrieve(const retrieve_spec& spec);
/// `<retrieves>` (AIR.Retrieves content); at least one spec (API_MISUSE otherwise).
[[nodiscard]] std::string encode_retrieves(const std::vector<retrieve_spec>& specs);

/// Read a `<capabilities protocol server>` element (OA-CAP-1); CONTENT_INVALID when it is not.
[[nodiscard]] capabilities parse_capabilities(std::string_view content);
/// Read an `<objectcollection>` of stored copies (OA-RET-7); empty content is no message.
/// `chunks` are the reply frame's chunks: each copy gets those its own `binarysizes` lists, in
/// document order (its attachments, OA-RET-19, OA-MSG-21). CONTENT_INVALID when it is something
/// else, or the chunks do not match the copies' lists.
[[nodiscard]] std::vector<message> parse_message_collection(std::string_view content,
                                                            std::vector<std::string> chunks = {});
/// Take an `AIR.Instruct.Wakeup` apart (spec 8.7, 8.8); CONTENT_INVALID when its content is not
/// an objectdictionary of TriggerMessage, RetrievedMessages and PhaseSpec objects.
[[nodiscard]] wakeup parse_wakeup(const message& msg);

}  // namespace openair
