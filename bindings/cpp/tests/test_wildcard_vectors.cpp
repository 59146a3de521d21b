// Every row of spec/vectors/wildcards/wildcards.json against the validators and the matcher.
#include <gtest/gtest.h>

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
