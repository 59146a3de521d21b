// Every case of spec/vectors/frames: fed whole, one byte at a time and in random splits.
#include <gtest/gtest.h>

#include <optional>
#include <random>

#include "openair/frame.hpp"
#include "support.hpp"

namespace openair {
namespace {

struct frame_case {
    std::string name;
    json::value spec;
};

std::vector<frame_case> load_cases() {
    std::vector<frame_case> out;
    json::value manifest = test::load_manifest("frames/manifest.json");
    for (const json::value& c : manifest.at("cases").as_array()) {
        out.push_back({c.at("name").as_string(), c});
    }
    return out;
}

// gtest prints parameters in failure messages and test names: the case name says it all.
void PrintTo(const frame_case& c, std::ostream* os) {
    *os << c.name;
}

std::string case_name(const testing::TestParamInfo<frame_case>& info) {
    std::string name = info.param.name;
    for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    }
    return name;
}

struct outcome {
    std::vector<frame> frames;
    std::optional<errc> failure;
    std::size_t failed_after = 0;  // bytes fed when the error was reported
    bool at_eof = false;
};

frame_limits limits_of(const json::value& c) {
    frame_limits limits;
    if (const json::value* l = c.find("limits")) {
        limits.max_xml = static_cast<std::uint64_t>(l->at("max_xml").as_int());
        limits.max_binary = static_cast<std::uint64_t>(l->at("max_binary").as_int());
    }
    return limits;
}

/// Feed `bytes` in the pieces given by `cuts` (end offsets), taking frames after each feed.
outcome run(const std::string& bytes, const frame_limits& limits,
            const std::vector<std::size_t>& cuts) {
    frame_reader reader(limits);
    outcome out;
    std::size_t fed = 0;
    try {
        for (std::size_t cut : cuts) {
            reader.feed(std::string_view(bytes).substr(fed, cut - fed));
            fed = cut;
            while (auto f = reader.next()) out.frames.push_back(std::move(*f));
        }
        out.at_eof = true;
        reader.feed_eof();
        while (auto f = reader.next()) out.frames.push_back(std::move(*f));
    } catch (const error& e) {
        out.failure = e.code();
        out.failed_after = fed;
        // OA-FRAME-9: the failure is sticky, for every later operation.
        EXPECT_THROW((void)reader.next(), error);
        try {
            reader.feed("x");
            ADD_FAILURE() << "feed after a framing error must throw";
        } catch (const error& again) {
            EXPECT_EQ(again.code(), e.code());
        }
        EXPECT_EQ(reader.buffered(), 0u);
    }
    return out;
}

void expect_frames(const std::vector<frame>& got, const json::array& want) {
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
        SCOPED_TRACE("frame " + std::to_string(i));
        const json::value& w = want[i];
        EXPECT_EQ(frame_tag_name(got[i].tag), w.at("tag").as_string());
        EXPECT_EQ(static_cast<std::int64_t>(got[i].xml.size()), w.at("xml_len").as_int());
        EXPECT_EQ(test::sha256_hex(got[i].xml), w.at("xml_sha256").as_string());
        const json::array& sizes = w.at("chunks").as_array();
        const json::array& hashes = w.at("chunks_sha256").as_array();
        ASSERT_EQ(got[i].chunks.size(), sizes.size());
        for (std::size_t k = 0; k < sizes.size(); ++k) {
            EXPECT_EQ(static_cast<std::int64_t>(got[i].chunks[k].size()), sizes[k].as_int());
            EXPECT_EQ(test::sha256_hex(got[i].chunks[k]), hashes[k].as_string());
        }
    }
}

void expect_outcome(const outcome& got, const json::value& expected) {
    expect_frames(got.frames, expected.at("frames").as_array());
    if (const json::value* name = expected.find("error")) {
        ASSERT_TRUE(got.failure.has_value()) << "expected " << name->as_string();
        EXPECT_EQ(errc_name(*got.failure), name->as_string());
        EXPECT_EQ(static_cast<std::int64_t>(got.frames.size()),
                  expected.at("after_frames").as_int());
        EXPECT_FALSE(got.at_eof) << "the error must be found before the end of the stream";
        return;
    }
    if (expected.at("then").as_string() == "ok") {
        EXPECT_FALSE(got.failure.has_value()) << errc_name(*got.failure);
    } else {
        ASSERT_TRUE(got.failure.has_value());
        EXPECT_EQ(*got.failure, errc::frame_truncated);  // OA-FRAME-8
        EXPECT_TRUE(got.at_eof);
    }
}

class FrameVectors : public testing::TestWithParam<frame_case> {
protected:
    std::string bytes() const {
        return test::read_file(test::vectors_dir() + "/frames/" +
                               GetParam().spec.at("file").as_string());
    }
};

TEST_P(FrameVectors, WholeBuffer) {
    std::string data = bytes();
    std::vector<std::size_t> cuts;
    if (!data.empty()) cuts.push_back(data.size());
    expect_outcome(run(data, limits_of(GetParam().spec), cuts), GetParam().spec.at("expected"));
}

TEST_P(FrameVectors, OneByteAtATime) {
    std::string data = bytes();
    std::vector<std::size_t> cuts;
    for (std::size_t i = 1; i <= data.size(); ++i) cuts.push_back(i);
    const json::value& expected = GetParam().spec.at("expected");
    outcome got = run(data, limits_of(GetParam().spec), cuts);
    expect_outcome(got, expected);
    if (const json::value* by = expected.find("error_by")) {
        // OA-FRAME-7: refused as soon as the refusing part is complete, never later; only an
        // unknown tag may be refused earlier (at the first byte that cannot start a tag).
        auto limit = static_cast<std::size_t>(by->as_int());
        if (expected.at("error").as_string() == "FRAME_UNKNOWN_TAG") {
            EXPECT_LE(got.failed_after, limit);
        } else {
            EXPECT_EQ(got.failed_after, limit);
        }
    }
}

TEST_P(FrameVectors, RandomSplits) {
    std::string data = bytes();
    for (unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        std::mt19937 gen(seed);
        std::vector<std::size_t> cuts;
        std::size_t at = 0;
        while (at < data.size()) {
            std::uniform_int_distribution<std::size_t> step(
                1, std::max<std::size_t>(1, data.size() / 3));
            at = std::min(data.size(), at + step(gen));
            cuts.push_back(at);
        }
        expect_outcome(run(data, limits_of(GetParam().spec), cuts), GetParam().spec.at("expected"));
    }
}

INSTANTIATE_TEST_SUITE_P(Manifest, FrameVectors, testing::ValuesIn(load_cases()), case_name);

}  // namespace
}  // namespace openair
