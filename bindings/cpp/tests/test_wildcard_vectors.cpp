// Every row of spec/vectors/wildcards/wildcards.json against the validators and the matcher.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "openair/error.hpp"
#include "openair/types.hpp"
#include "support.hpp"

namespace openair {
namespace {

std::string answer(const std::string& pattern, const std::string& type) {
    if (!is_valid_pattern(pattern)) return "invalid-pattern";  // checked first (README)
    if (!is_valid_type(type)) return "invalid-type";
    return matches(pattern, type) ? "match" : "nomatch";
}

TEST(WildcardVectors, EveryRow) {
    json::value manifest = test::load_manifest("wildcards/wildcards.json");
    ASSERT_EQ(manifest.at("format").as_string(), "openair-wildcard-vectors/1");
    const json::value& limits = manifest.at("limits");
    ASSERT_EQ(static_cast<std::size_t>(limits.at("max_bytes").as_int()), max_type_bytes);
    ASSERT_EQ(static_cast<std::size_t>(limits.at("max_segments").as_int()), max_type_segments);
    std::size_t rows = 0;
    for (const json::value& row : manifest.at("rows").as_array()) {
        const std::string& pattern = row.at("pattern").as_string();
        const std::string& type = row.at("type").as_string();
        EXPECT_EQ(answer(pattern, type), row.at("expected").as_string())
            << "pattern '" << pattern << "' type '" << type << "' (" << row.at("source").as_string()
            << ")";
        ++rows;
    }
    EXPECT_GT(rows, 1000u);
}

std::string utf8(char32_t cp) {
    std::string out;
    if (cp < 0x80) {
        out += static_cast<char>(cp);
    } else if (cp < 0x800) {
        out += static_cast<char>(0xC0 | (cp >> 6));
        out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
        out += static_cast<char>(0xE0 | (cp >> 12));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
        out += static_cast<char>(0xF0 | (cp >> 18));
        out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
    }
    return out;
}

// The table of spec 5.1 (OA-TYPE-5) is the shared vector file: both ends of every range are
// refused, and the code points just outside a range are accepted unless another range holds
// them. Surrogates (Cs) cannot be written in UTF-8 and are refused by the decoder instead.
TEST(WildcardVectors, ExcludedTableIsTheSharedVectorFile) {
    json::value table = test::load_manifest("unicode/segment-exclusions.json");
    ASSERT_EQ(table.at("unicode_version").as_string(), "14.0.0");
    std::vector<std::pair<char32_t, char32_t>> ranges;
    for (const json::value& r : table.at("ranges").as_array()) {
        auto cp = [&](const char* key) {
            return static_cast<char32_t>(std::stoul(r.at(key).as_string().substr(2), nullptr, 16));
        };
        ranges.emplace_back(cp("first"), cp("last"));
    }
    auto excluded = [&](char32_t cp) {
        return std::any_of(ranges.begin(), ranges.end(),
                           [cp](const auto& r) { return cp >= r.first && cp <= r.second; });
    };
    ASSERT_GT(ranges.size(), 30u);
    for (const auto& [first, last] : ranges) {
        for (char32_t cp : {first, last, char32_t(first - 1), char32_t(last + 1)}) {
            if (cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF) || cp == '.' || cp == '*') continue;
            EXPECT_EQ(is_valid_type("A" + utf8(cp) + "B"), !excluded(cp)) << "U+" << std::hex << cp;
        }
    }
}

TEST(WildcardVectors, ValidatorsThrowTheirConditions) {
    EXPECT_EQ(validate_type("Test.Ping"), "Test.Ping");
    EXPECT_EQ(validate_pattern("Test.*"), "Test.*");
    try {
        (void)validate_type("Test..Ping");
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::type_invalid);
    }
    try {
        (void)validate_pattern("A.**");
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::pattern_invalid);
    }
}

TEST(WildcardVectors, HostilePatternIsLinear) {
    // A backtracking matcher takes exponential time here; this one answers at once.
    std::string pattern;
    for (int i = 0; i < 100; ++i) pattern += "*A";
    pattern += "*B";
    std::string type(250, 'A');
    EXPECT_FALSE(matches(pattern, type));
}

}  // namespace
}  // namespace openair
