// Internal: the number forms of the wire (spec 1.4): decimal integers and xs:decimal values.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace openair::detail {

/// A decimal integer: optional sign (when `allow_minus` / `allow_plus`), then ASCII digits.
/// Surrounding XML white space is ignored. nullopt when malformed or outside int64.
[[nodiscard]] std::optional<std::int64_t> parse_int64(std::string_view text, bool allow_minus,
                                                      bool allow_plus = true);
/// ASCII digits only (no sign), surrounding XML white space ignored; nullopt when malformed or
/// outside uint64.
[[nodiscard]] std::optional<std::uint64_t> parse_uint64(std::string_view text);
/// An xs:decimal (`[+-]?(digits[.digits*] | .digits)`, no exponent), surrounding white space
/// ignored; nullopt when malformed. -0.0 reads as 0.0.
[[nodiscard]] std::optional<double> parse_decimal(std::string_view text);
/// The shortest decimal that reads back as `value`, never an exponent, always with a fraction:
/// 2.0, 0.5, 6.999, 0.00001. `value` must be finite.
[[nodiscard]] std::string format_decimal(double value);
/// Whether `text` is one or more ASCII digits.
[[nodiscard]] bool all_digits(std::string_view text) noexcept;

}  // namespace openair::detail
