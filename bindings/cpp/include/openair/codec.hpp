// Message <-> XML (spec sections 3, 4, 14.2): the lenient reader and the canonical writer.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "openair/frame.hpp"
#include "openair/message.hpp"

namespace openair {

inline constexpr std::size_t default_max_xml_depth = 64;  // OA-LIM-3

/// Bounds on one parsed document (OA-LIM-1, OA-LIM-3).
struct xml_limits {
    std::size_t max_bytes = default_max_xml;
    std::size_t max_depth = default_max_xml_depth;  ///< the root element is depth 1
};

/// Parse the XML of a Message or Receive frame into a message carrying `chunks`.
///
/// Accepts every legacy spelling (OA-MSG-3), slots in any order (OA-MSG-16), and keeps unknown
/// slots in order (OA-MSG-5). The parser loads no DTD, expands no entity, touches no network
/// (OA-SEC-1/2) and bounds depth (OA-LIM-3). Throws XML_MALFORMED (also when the root is not
/// `message`), XML_FORBIDDEN, XML_TOO_DEEP and MESSAGE_INVALID.
///
/// `clamp_priority` reads a priority outside 0.0-6.999 as the nearest end of the range instead
/// of refusing it (Psyclone echoes a posted 6.999 as `7.00`): what a client does with the
/// deliveries and replies it receives (OA-MSG-19). Stored copies nested in content
/// (`find_message`, wakeups, retrieve results) are always read that way.
[[nodiscard]] message decode_message(std::string_view xml, std::vector<std::string> chunks = {},
                                     const xml_limits& limits = {}, bool clamp_priority = false);

/// Decode a Message or Receive frame; a BinaryM frame carries no message (MESSAGE_INVALID).
[[nodiscard]] message from_frame(const frame& f, const xml_limits& limits = {},
                                 bool clamp_priority = false);

/// Write `msg` in the canonical form of spec 3.5 (byte for byte what
/// spec/vectors/messages/*.canonical.xml hold): UTF-8, no declaration, no indentation.
///
/// Throws API_MISUSE for a message that cannot be written: an empty type, a priority outside
/// 0.0-6.999, a character XML 1.0 forbids (OA-MSG-14), XML content that is not well-formed, an
/// unknown slot whose name is not an XML name or is the name of a known slot.
[[nodiscard]] std::string encode_message(const message& msg);

/// The Message (or Receive) frame for `msg`; its binary chunks follow the XML.
[[nodiscard]] frame to_frame(const message& msg, frame_tag tag = frame_tag::message);

/// The first `<message>` found depth-first inside XML content (a stored copy in a wakeup or a
/// retrieve result), decoded; nullopt when there is none. Throws as `decode_message`.
[[nodiscard]] std::optional<message> find_message(std::string_view xml_content);

}  // namespace openair
