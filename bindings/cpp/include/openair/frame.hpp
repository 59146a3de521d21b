// OpenAIR frames (spec section 2): the incremental frame reader and the frame encoder. No I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "openair/error.hpp"

namespace openair {

inline constexpr std::size_t frame_header_size = 12;              // tag, NUL, uint32 length
inline constexpr std::uint64_t default_max_xml = 16ull << 20;     // OA-LIM-1
inline constexpr std::uint64_t default_max_binary = 64ull << 20;  // OA-LIM-2

/// The three frame tags (OA-FRAME-2), compared byte for byte.
enum class frame_tag { message, receive, binary };

/// The 7-byte wire spelling of a tag: `Message`, `Receive` or `BinaryM`.
[[nodiscard]] std::string_view frame_tag_name(frame_tag tag) noexcept;

/// One frame. Message/Receive: `xml` is the message XML and `chunks` the binary chunks after it
/// (OA-FRAME-4). BinaryM: `xml` is empty and `chunks` holds the one chunk (OA-FRAME-5).
struct frame {
    frame_tag tag = frame_tag::message;
    std::string xml;
    std::vector<std::string> chunks;
};

/// What one frame may announce before the reader refuses it (OA-FRAME-7).
struct frame_limits {
    std::uint64_t max_xml = default_max_xml;        ///< the largest L of a Message/Receive frame
    std::uint64_t max_binary = default_max_binary;  ///< the largest chunk total (or BinaryM L)
};

/// The bytes of `f`: header, body, then the chunks. Throws API_MISUSE when a body does not fit
/// the uint32 length, or a BinaryM frame does not carry exactly one chunk and no XML.
[[nodiscard]] std::string encode_frame(const frame& f);

/// The chunk sizes a message's `binarysizes` slot announces (OA-FRAME-4, OA-FRAME-13).
///
/// XML that cannot be parsed, or whose root is not `message`, announces none. Throws
/// BINARY_SIZES_INVALID for a slot that is not a list of non-negative integers, a repeated slot
/// or a `totalbinarysize` that is not their sum; BINARY_TOO_LARGE when the total exceeds
/// `max_binary`.
[[nodiscard]] std::vector<std::uint64_t> binary_sizes(
    std::string_view xml, std::uint64_t max_binary = default_max_binary);

/// Cut a byte stream into frames, incrementally and without I/O (OA-FRAME-11).
///
/// `feed` bytes as they arrive and call `next` until it returns nullopt. Limits are checked as
/// soon as the header (or the XML, for `binarysizes`) is complete, before the rest of the frame
/// is awaited (OA-FRAME-7). The first framing error is sticky (OA-FRAME-9): it is thrown again by
/// every later `feed`, `next` and `feed_eof`, and no later byte is kept.
class frame_reader {
public:
    explicit frame_reader(frame_limits limits = {}) : limits_(limits) {}

    /// Append received bytes; throws the sticky error once the stream has failed.
    void feed(std::string_view data);
    /// The next complete frame, or nullopt until more bytes arrive. Throws FRAME_UNKNOWN_TAG,
    /// FRAME_TOO_LARGE, BINARY_TOO_LARGE, BINARY_SIZES_INVALID, and FRAME_TRUNCATED once the
    /// end of the stream was signalled inside a frame.
    [[nodiscard]] std::optional<frame> next();
    /// Signal the end of the stream. Complete frames still held stay available from `next`; a
    /// partial frame is discarded and reported as FRAME_TRUNCATED (OA-FRAME-8), at once when
    /// no complete frame precedes it.
    void feed_eof();

    /// The sticky framing error, if the stream has failed.
    [[nodiscard]] const std::optional<error>& failure() const noexcept { return error_; }
    /// How many received bytes have not been returned as part of a frame yet.
    [[nodiscard]] std::size_t buffered() const noexcept { return buf_.size() - pos_; }
    /// True while bytes of an unfinished frame are held (an adapter times OA-FRAME-12 with it).
    /// Meaningful after `next` returned nullopt.
    [[nodiscard]] bool in_frame() const noexcept { return !error_ && buffered() > 0; }
    [[nodiscard]] const frame_limits& limits() const noexcept { return limits_; }

private:
    [[noreturn]] void fail(const error& e);
    void throw_if_failed() const;
    std::optional<frame> advance();
    bool read_header();
    frame take(std::uint64_t length, std::uint64_t end);

    frame_limits limits_;
    std::string buf_;
    std::size_t pos_ = 0;
    std::optional<frame_tag> tag_;                     // set once the header is valid
    std::optional<std::vector<std::uint64_t>> sizes_;  // set once the chunk sizes are known
    std::optional<frame> pending_;                     // a complete frame feed_eof found
    bool eof_ = false;
    std::optional<error> error_;
};

}  // namespace openair
