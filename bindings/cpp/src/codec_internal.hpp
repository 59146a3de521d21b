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
/// Hands out a frame's chunks to the stored copies nested in its content, in document order
/// (attachments, OA-MSG-21): each copy gets as many as its own `binarysizes` lists.
class chunk_cursor {
public:
    explicit chunk_cursor(std::vector<std::string> chunks) : chunks_(std::move(chunks)) {}
    /// The chunks of the nested `<message>` element `el`; CONTENT_INVALID when the frame has
    /// fewer left, or their sizes differ from its list (OA-MSG-21).
    [[nodiscard]] std::vector<std::string> take(const xmlNode* el);
    /// CONTENT_INVALID when chunks are left that no nested copy lists (OA-MSG-21).
    void finish() const;

private:
    std::vector<std::string> chunks_;
    std::size_t next_ = 0;
};

/// Read the messages of an `<objectcollection>` element (CONTENT_INVALID when it is not one);
/// with `cursor`, each gets its attachments from it.
[[nodiscard]] std::vector<message> read_message_collection(const xmlNode* root,
                                                           chunk_cursor* cursor = nullptr);
/// Append the canonical `<message>` element for `msg` (spec 3.5). `chunk_sizes`, when given,
/// are the sizes `binarysizes` announces instead of those of `msg.binary` (chunks sent apart).
void write_message(std::string& out, const message& msg,
                   const std::vector<std::uint64_t>* chunk_sizes = nullptr);
/// Append `<name sec msec [usec]/>`.
void write_time(xml_writer& w, std::string_view name, const air_time& t);

}  // namespace openair::detail
