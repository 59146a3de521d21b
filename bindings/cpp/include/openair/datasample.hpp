// Data samples and their binary chunk (spec 11.2, OA-STREAM-2, OA-STREAM-10). No I/O: the
// chunk codec is tested on its own against spec/vectors/samples/chunks.json.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#if __cplusplus >= 202002L
#include <span>
#endif

namespace openair {

/// A read-only view of bytes: what the stream API takes and gives for payloads, without copies.
///
/// The library is C++17, so this is its own small span; under C++20 it converts to and from
/// `std::span<const std::byte>`. It converts implicitly from `std::vector<std::byte>`,
/// `std::string` and `std::string_view` (bytes held as char). It does not own the bytes.
class bytes_view {
public:
    constexpr bytes_view() noexcept = default;
    constexpr bytes_view(const std::byte* data, std::size_t size) noexcept
        : data_(data), size_(size) {}
    bytes_view(const void* data, std::size_t size) noexcept
        : data_(static_cast<const std::byte*>(data)), size_(size) {}
    bytes_view(const std::vector<std::byte>& v) noexcept  // NOLINT: implicit on purpose
        : data_(v.data()), size_(v.size()) {}
    bytes_view(std::string_view s) noexcept  // NOLINT: implicit on purpose
        : data_(reinterpret_cast<const std::byte*>(s.data())), size_(s.size()) {}
    bytes_view(const std::string& s) noexcept  // NOLINT: implicit on purpose
        : bytes_view(std::string_view(s)) {}
#if __cplusplus >= 202002L
    constexpr bytes_view(std::span<const std::byte> s) noexcept  // NOLINT: implicit
        : data_(s.data()), size_(s.size()) {}
    [[nodiscard]] constexpr operator std::span<const std::byte>() const noexcept {
        return {data_, size_};
    }
#endif

    [[nodiscard]] constexpr const std::byte* data() const noexcept { return data_; }
    [[nodiscard]] constexpr std::size_t size() const noexcept { return size_; }
    [[nodiscard]] constexpr bool empty() const noexcept { return size_ == 0; }
    [[nodiscard]] constexpr const std::byte* begin() const noexcept { return data_; }
    [[nodiscard]] constexpr const std::byte* end() const noexcept { return data_ + size_; }
    [[nodiscard]] constexpr std::byte operator[](std::size_t i) const noexcept { return data_[i]; }
    /// The same bytes as chars (for APIs that take text buffers).
    [[nodiscard]] std::string_view chars() const noexcept {
        return {reinterpret_cast<const char*>(data_), size_};
    }
    /// A copy of the bytes.
    [[nodiscard]] std::vector<std::byte> to_vector() const { return {begin(), end()}; }

private:
    const std::byte* data_ = nullptr;
    std::size_t size_ = 0;
};

/// A sample's parameters, in chunk order: `key%equals%value` pairs (spec 11.2).
using sample_params = std::vector<std::pair<std::string, std::string>>;

inline constexpr std::string_view builtin_id = "builtin:id";
inline constexpr std::string_view builtin_timestamp = "builtin:timestamp";
inline constexpr std::string_view builtin_seq = "builtin:seq";
inline constexpr std::size_t default_max_params = 4096;  // a receiver's bound on pairs

/// One received data sample. It owns the chunk it was decoded from; `payload()` is a view into
/// it (no copy).
class data_sample {
public:
    data_sample() = default;

    /// Decode a datasample chunk (OA-STREAM-10); SAMPLE_INVALID when it is malformed. The chunk
    /// is moved in and kept: the payload is not copied out of it.
    [[nodiscard]] static data_sample decode(std::string chunk,
                                            std::size_t max_params = default_max_params);

    [[nodiscard]] bytes_view payload() const noexcept {
        return {chunk_.data() + payload_offset, payload_size_};
    }
    [[nodiscard]] std::size_t size() const noexcept { return payload_size_; }
    [[nodiscard]] const sample_params& params() const noexcept { return params_; }
    /// The first parameter called `key` (a reader takes a key's first occurrence, spec 11.2).
    [[nodiscard]] std::optional<std::string> param(std::string_view key) const;
    /// `builtin:id`, `builtin:timestamp` (ms since the epoch) and `builtin:seq` as integers;
    /// nullopt when absent or not a decimal integer.
    [[nodiscard]] std::optional<std::int64_t> id() const;
    [[nodiscard]] std::optional<std::int64_t> timestamp_ms() const;
    [[nodiscard]] std::optional<std::int64_t> seq() const;
    /// The whole chunk, as received.
    [[nodiscard]] const std::string& chunk() const noexcept { return chunk_; }

private:
    static constexpr std::size_t payload_offset = 4;
    std::string chunk_;
    std::size_t payload_size_ = 0;
    sample_params params_;
};

/// Why `key`/`value` cannot be written (OA-STREAM-2), or an empty string when they can.
[[nodiscard]] std::string param_problem(std::string_view key, std::string_view value);
/// The parameter string of a chunk; API_MISUSE for a pair OA-STREAM-2 forbids.
[[nodiscard]] std::string encode_params(const sample_params& params);
/// Read a parameter string (without its NUL); SAMPLE_INVALID as OA-STREAM-10 says.
[[nodiscard]] sample_params decode_params(std::string_view text,
                                          std::size_t max_params = default_max_params);

/// A chunk in three parts, so that a writer can send the payload from where it lies: `head`
/// (the 4-byte length), the payload view, `tail` (the parameters and the NUL).
struct chunk_parts {
    std::string head;
    bytes_view payload;
    std::string tail;

    [[nodiscard]] std::size_t size() const noexcept {
        return head.size() + payload.size() + tail.size();
    }
};
/// Split a sample into its chunk parts; API_MISUSE for bad parameters or a payload that does
/// not fit the 32-bit length.
[[nodiscard]] chunk_parts make_chunk_parts(bytes_view payload, const sample_params& params);
/// The whole chunk, joined (one copy of the payload).
[[nodiscard]] std::string encode_chunk(bytes_view payload, const sample_params& params);

}  // namespace openair
