// Message types, trigger/retrieve patterns and the wildcard matcher (spec section 5).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace openair {

inline constexpr std::size_t max_type_bytes = 255;    // OA-TYPE-4
inline constexpr std::size_t max_type_segments = 32;  // OA-TYPE-4

/// Why `t` is not a valid message type, or nullopt when it is one (OA-TYPE-1..4): non-empty
/// segments separated by single dots, no white space, no control or format character, no `*`,
/// at most `max_bytes` UTF-8 bytes and `max_segments` segments (0 disables a limit).
[[nodiscard]] std::optional<std::string> type_problem(std::string_view t,
                                                      std::size_t max_bytes = max_type_bytes,
                                                      std::size_t max_segments = max_type_segments);
/// Why `p` is not a valid pattern, or nullopt (OA-MATCH-7): the type rules, except that `*` may
/// appear inside segments but never twice in a row. The type limits apply to patterns too.
[[nodiscard]] std::optional<std::string> pattern_problem(
    std::string_view p, std::size_t max_bytes = max_type_bytes,
    std::size_t max_segments = max_type_segments);

[[nodiscard]] inline bool is_valid_type(std::string_view t) {
    return !type_problem(t);
}
[[nodiscard]] inline bool is_valid_pattern(std::string_view p) {
    return !pattern_problem(p);
}
/// Return `t` unchanged when valid, else throw TYPE_INVALID.
std::string_view validate_type(std::string_view t);
/// Return `p` unchanged when valid, else throw PATTERN_INVALID.
std::string_view validate_pattern(std::string_view p);

/// `text` with `A`-`Z` lowered and every other byte unchanged (OA-MATCH-1).
[[nodiscard]] std::string ascii_fold(std::string_view text);

/// Whether `pattern` matches the message type `type` (OA-MATCH-1..6), exactly as the reference
/// `openair.protocol.matching.matches()`: ASCII case ignored; `*` any run of characters, dots included;
/// no prefix matching; a pattern ending in `.*` also matches the type equal to the pattern
/// without that `.*` (OA-MATCH-4). Linear in the input; inputs are assumed valid.
[[nodiscard]] bool matches(std::string_view pattern, std::string_view type);

}  // namespace openair
