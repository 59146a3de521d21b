#include "numbers.hpp"

#include <charconv>
#include <limits>
#include <system_error>

#include "xml.hpp"

namespace openair::detail {

bool all_digits(std::string_view text) noexcept {
    if (text.empty()) return false;
    for (char c : text) {
        if (c < '0' || c > '9') return false;
    }
    return true;
}

std::optional<std::int64_t> parse_int64(std::string_view text, bool allow_minus, bool allow_plus) {
    std::string_view s = strip_ws(text);
    bool negative = false;
    if (!s.empty() && ((s[0] == '-' && allow_minus) || (s[0] == '+' && allow_plus))) {
        negative = s[0] == '-';
        s.remove_prefix(1);
    }
    if (!all_digits(s)) return std::nullopt;
    // Accumulate as a negative number so that INT64_MIN fits.
    std::int64_t value = 0;
    constexpr std::int64_t lowest = std::numeric_limits<std::int64_t>::min();
    for (char c : s) {
        int digit = c - '0';
        if (value < (lowest + digit) / 10) return std::nullopt;
        value = value * 10 - digit;
    }
    if (negative) return value;
    if (value == lowest) return std::nullopt;
    return -value;
}

std::optional<std::uint64_t> parse_uint64(std::string_view text) {
    std::string_view s = strip_ws(text);
    if (!all_digits(s)) return std::nullopt;
    std::uint64_t value = 0;
    constexpr std::uint64_t highest = std::numeric_limits<std::uint64_t>::max();
    for (char c : s) {
        auto digit = static_cast<std::uint64_t>(c - '0');
        if (value > (highest - digit) / 10) return std::nullopt;
        value = value * 10 + digit;
    }
    return value;
}

std::optional<double> parse_decimal(std::string_view text) {
    std::string_view s = strip_ws(text);
    bool negative = false;
    if (!s.empty() && (s[0] == '+' || s[0] == '-')) {
        negative = s[0] == '-';
        s.remove_prefix(1);
    }
    std::size_t dot = s.find('.');
    std::string_view whole = s.substr(0, dot);
    std::string_view frac = dot == std::string_view::npos ? std::string_view() : s.substr(dot + 1);
    bool whole_ok = whole.empty() || all_digits(whole);
    bool frac_ok = frac.empty() || all_digits(frac);
    if (!whole_ok || !frac_ok || (whole.empty() && frac.empty())) return std::nullopt;
    double value = 0.0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (ec == std::errc::result_out_of_range) {
        // Too many digits for a double: huge values are infinite, tiny ones are zero.
        bool zero_whole = whole.find_first_not_of('0') == std::string_view::npos;
        value = zero_whole ? 0.0 : std::numeric_limits<double>::infinity();
    } else if (ec != std::errc() || end != s.data() + s.size()) {
        return std::nullopt;
    }
    return (negative ? -value : value) + 0.0;  // + 0.0 turns -0.0 into 0.0
}

std::string format_decimal(double value) {
    char buf[400];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, value + 0.0, std::chars_format::fixed);
    std::string out = ec == std::errc() ? std::string(buf, end) : std::string("0");
    if (out.find('.') == std::string::npos) out += ".0";
    return out;
}

}  // namespace openair::detail
