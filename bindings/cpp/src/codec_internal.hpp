// Internal: codec pieces shared by the content-object readers and writers.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "openair/message.hpp"
#include "xml.hpp"

namespace openair::detail {

/// The attributes of `el` keyed by lower-cased name; a name given twice is MESSAGE_INVALID.
[[nodiscard]] std::map<std::string, std::string> attributes(const xmlNode* el);
/// Read a time element (OA-TIME-1): `sec`, `msec` (or `ms`), `usec`; `tzc` is ignored.
[[nodiscard]] air_time read_time(const xmlNode* el);
/// Read a `<message>` element (any case) into a message carrying `chunks`. A stored copy nested
/// in content is what a server wrote, so by default an out-of-range priority is clamped
/// (OA-MSG-19); a server reading a post passes false (OA-MSG-6).
[[nodiscard]] message decode_element(const xmlNode* root, std::vector<std::string> chunks,
                                     bool clamp_priority = true);
/// Read the messages of an `<objectcollection>` element (CONTENT_INVALID when it is not one).
[[nodiscard]] std::vector<message> read_message_collection(const xmlNode* root);
/// Append the canonical `<message>` element for `msg` (spec 3.5).
void write_message(std::string& out, const message& msg);
/// Append `<name sec msec [usec]/>`.
void write_time(xml_writer& w, std::string_view name, const air_time& t);

}  // namespace openair::detail
