// Type and pattern validation and the wildcard matcher (spec section 5).
#include "openair/types.hpp"

#include <algorithm>
#include <vector>

#include "openair/error.hpp"

namespace openair {

namespace {

struct range {
    char32_t first;
    char32_t last;
};

// Characters that may not appear in a type or pattern (OA-TYPE-1, OA-TYPE-5, OA-MATCH-7): the
// table of spec 5.1, the Unicode 14.0.0 categories Cc, Cf, Co, Zl, Zp and Zs (Cs cannot be
// decoded from UTF-8), e.g. U+200B ZERO WIDTH SPACE; adjacent ranges merged. It is the shared
// vector file spec/vectors/unicode/segment-exclusions.json, which test_wildcard_vectors.cpp
// compares with this table. Unassigned code points are segment characters.
constexpr range refused[] = {
    {0x0, 0x20},        {0x7F, 0xA0},       {0xAD, 0xAD},       {0x600, 0x605},
    {0x61C, 0x61C},     {0x6DD, 0x6DD},     {0x70F, 0x70F},     {0x890, 0x891},
    {0x8E2, 0x8E2},     {0x1680, 0x1680},   {0x180E, 0x180E},   {0x2000, 0x200F},
    {0x2028, 0x202F},   {0x205F, 0x2064},   {0x2066, 0x206F},   {0x3000, 0x3000},
    {0xE000, 0xF8FF},   {0xFEFF, 0xFEFF},   {0xFFF9, 0xFFFB},   {0x110BD, 0x110BD},
    {0x110CD, 0x110CD}, {0x13430, 0x13438}, {0x1BCA0, 0x1BCA3}, {0x1D173, 0x1D17A},
    {0xE0001, 0xE0001}, {0xE0020, 0xE007F}, {0xF0000, 0xFFFFD}, {0x100000, 0x10FFFD},
};

bool is_refused(char32_t cp) {
    return std::any_of(std::begin(refused), std::end(refused),
                       [cp](const range& r) { return cp >= r.first && cp <= r.last; });
}

bool is_space(char32_t cp) {
    return (cp >= 0x9 && cp <= 0xD) || (cp >= 0x1C && cp <= 0x20) || cp == 0x85 || cp == 0xA0 ||
           cp == 0x1680 || (cp >= 0x2000 && cp <= 0x200A) || cp == 0x2028 || cp == 0x2029 ||
           cp == 0x202F || cp == 0x205F || cp == 0x3000;
}

/// Decode UTF-8; nullopt when the bytes are not UTF-8.
std::optional<std::vector<char32_t>> code_points(std::string_view s) {
    std::vector<char32_t> out;
    for (std::size_t i = 0; i < s.size();) {
        auto b = static_cast<unsigned char>(s[i]);
        std::size_t len = b < 0x80 ? 1 : b >= 0xF0 ? 4 : b >= 0xE0 ? 3 : b >= 0xC2 ? 2 : 0;
        if (len == 0 || b > 0xF4 || i + len > s.size()) return std::nullopt;
        char32_t cp = len == 1 ? b : (b & (0x7F >> len));
        for (std::size_t k = 1; k < len; ++k) {
            auto c = static_cast<unsigned char>(s[i + k]);
            if ((c & 0xC0) != 0x80) return std::nullopt;
            cp = (cp << 6) | (c & 0x3F);
        }
        if ((len == 3 && cp < 0x800) || (len == 4 && (cp < 0x10000 || cp > 0x10FFFF)) ||
            (cp >= 0xD800 && cp <= 0xDFFF)) {
            return std::nullopt;
        }
        out.push_back(cp);
        i += len;
    }
    return out;
}

std::optional<std::string> problem(std::string_view text, bool pattern, std::size_t max_bytes,
                                   std::size_t max_segments) {
    if (text.empty()) return "is empty";  // OA-TYPE-1, OA-MSG-2
    auto cps = code_points(text);
    if (!cps) return "is not UTF-8";
    if (std::any_of(cps->begin(), cps->end(), is_space)) {
        return "contains whitespace";  // OA-TYPE-1, OA-MATCH-7
    }
    if (std::any_of(cps->begin(), cps->end(), is_refused)) {
        return "contains a non-printable character";  // OA-TYPE-1
    }
    if (!pattern && text.find('*') != std::string_view::npos) return "contains '*'";  // OA-TYPE-3
    if (pattern && text.find("**") != std::string_view::npos) {
        return "contains two consecutive '*'";  // OA-MATCH-7
    }
    if (text.front() == '.' || text.back() == '.' || text.find("..") != std::string_view::npos) {
        return "has an empty segment";  // OA-TYPE-1, OA-MATCH-7
    }
    auto dots = static_cast<std::size_t>(std::count(text.begin(), text.end(), '.'));
    if (max_segments != 0 && dots >= max_segments) {
        return "has more than " + std::to_string(max_segments) + " segments";  // OA-TYPE-4
    }
    if (max_bytes != 0 && text.size() > max_bytes) {
        return "is longer than " + std::to_string(max_bytes) + " bytes";  // OA-TYPE-4
    }
    return std::nullopt;
}

std::string shown(std::string_view text) {
    return text.size() <= 60 ? "'" + std::string(text) + "'"
                             : "'" + std::string(text.substr(0, 60)) + "...'";
}

/// Whether the whole of `t` matches `pattern`'s `*`-separated literal parts (OA-MATCH-3, -6).
bool glob(std::string_view p, std::string_view t) {
    std::size_t star = p.find('*');
    if (star == std::string_view::npos) return t == p;  // OA-MATCH-2: equality only
    std::size_t last_star = p.rfind('*');
    std::string_view pre = p.substr(0, star);
    std::string_view post = p.substr(last_star + 1);
    // OA-MATCH-6: prefix and suffix may not overlap, so the type is at least as long as both.
    if (t.size() < pre.size() + post.size()) return false;
    if (t.substr(0, pre.size()) != pre || t.substr(t.size() - post.size()) != post) return false;
    std::size_t end = t.size() - post.size();
    std::size_t pos = pre.size();
    // Taking the leftmost occurrence of each middle part is optimal for `*`-only globs, so one
    // pass decides (no backtracking).
    std::size_t from = star + 1;
    while (from <= last_star) {
        std::size_t next = p.find('*', from);
        std::string_view middle = p.substr(from, next - from);
        if (!middle.empty()) {
            std::size_t found = t.substr(0, end).find(middle, pos);
            if (found == std::string_view::npos) return false;
            pos = found + middle.size();
        }
        from = next + 1;
    }
    return true;
}

}  // namespace

std::optional<std::string> type_problem(std::string_view t, std::size_t max_bytes,
                                        std::size_t max_segments) {
    return problem(t, false, max_bytes, max_segments);
}

std::optional<std::string> pattern_problem(std::string_view p, std::size_t max_bytes,
                                           std::size_t max_segments) {
    return problem(p, true, max_bytes, max_segments);
}

std::string_view validate_type(std::string_view t) {
    if (auto why = type_problem(t))
        throw error(errc::type_invalid, "type " + shown(t) + " " + *why);
    return t;
}

std::string_view validate_pattern(std::string_view p) {
    if (auto why = pattern_problem(p)) {
        throw error(errc::pattern_invalid, "pattern " + shown(p) + " " + *why);
    }
    return p;
}

std::string ascii_fold(std::string_view text) {
    std::string out(text);
    for (char& c : out) {
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    }
    return out;
}

bool matches(std::string_view pattern, std::string_view type) {
    std::string p = ascii_fold(pattern);  // OA-MATCH-1
    std::string t = ascii_fold(type);
    if (glob(p, t)) return true;
    // OA-MATCH-4: `P.*` also matches the type equal to `P`, the remainder compared literally
    // (so `A.*.B.*` does not match `A.X.B` through this rule).
    return p.size() >= 2 && p.compare(p.size() - 2, 2, ".*") == 0 &&
           std::string_view(p).substr(0, p.size() - 2) == t;
}

}  // namespace openair
