// Every row of spec/vectors/samples/chunks.json against the datasample chunk codec (spec 11.2),
// plus the stream wire helpers that need no socket.
#include <gtest/gtest.h>

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "openair/datasample.hpp"
#include "openair/error.hpp"
#include "openair/stream.hpp"
#include "stream_wire.hpp"
#include "support.hpp"

namespace openair {
namespace {

sample_params params_of(const json::value& row) {
    sample_params out;
    for (const json::value& pair : row.at("params").as_array()) {
        const json::array& kv = pair.as_array();
        out.emplace_back(kv.at(0).as_string(), kv.at(1).as_string());
    }
    return out;
}

const json::value& manifest() {
    static const json::value m = test::load_manifest("samples/chunks.json");
    return m;
}

TEST(SampleVectors, Format) {
    EXPECT_EQ(manifest().at("format").as_string(), "openair-sample-vectors/1");
}

TEST(SampleVectors, ValidChunksDecodeAndEncodeBack) {
    std::size_t rows = 0;
    for (const json::value& row : manifest().at("valid").as_array()) {
        const std::string& name = row.at("name").as_string();
        std::string chunk = test::from_hex(row.at("chunk").as_string());
        std::string payload = test::from_hex(row.at("payload").as_string());
        sample_params params = params_of(row);
        data_sample s = data_sample::decode(chunk);
        EXPECT_EQ(std::string(s.payload().chars()), payload) << name;
        EXPECT_EQ(s.size(), payload.size()) << name;
        EXPECT_EQ(s.params(), params) << name;
        EXPECT_EQ(encode_chunk(bytes_view(payload), params), chunk) << name;
        chunk_parts parts = make_chunk_parts(bytes_view(payload), params);
        EXPECT_EQ(parts.head + std::string(parts.payload.chars()) + parts.tail, chunk) << name;
        ++rows;
    }
    EXPECT_GE(rows, 10u);
}

TEST(SampleVectors, InvalidChunksAreSampleInvalid) {
    std::size_t rows = 0;
    for (const json::value& row : manifest().at("invalid").as_array()) {
        const std::string& name = row.at("name").as_string();
        ASSERT_EQ(row.at("error").as_string(), "SAMPLE_INVALID") << name;
        auto max_params = static_cast<std::size_t>(row.get_int("max_params", 4096));
        std::string chunk = test::from_hex(row.at("chunk").as_string());
        try {
            (void)data_sample::decode(chunk, max_params);
            ADD_FAILURE() << name << ": decoded, should be refused ("
                          << row.at("reason").as_string() << ")";
        } catch (const error& e) {
            EXPECT_EQ(e.code(), errc::sample_invalid) << name << ": " << e.what();
        }
        ++rows;
    }
    EXPECT_GE(rows, 10u);
}

TEST(SampleVectors, UnencodableParamsAreApiMisuse) {
    std::size_t rows = 0;
    for (const json::value& row : manifest().at("unencodable").as_array()) {
        const std::string& name = row.at("name").as_string();
        ASSERT_EQ(row.at("error").as_string(), "API_MISUSE") << name;
        try {
            (void)encode_chunk(bytes_view(std::string("x")), params_of(row));
            ADD_FAILURE() << name << ": encoded, should be refused";
        } catch (const error& e) {
            EXPECT_EQ(e.code(), errc::api_misuse) << name << ": " << e.what();
        }
        ++rows;
    }
    EXPECT_GE(rows, 5u);
}

TEST(SampleCodec, BuiltinParamsReadAsIntegers) {
    std::string chunk = encode_chunk(bytes_view(std::string("ab")), {{"builtin:id", "42"},
                                                                     {"builtin:timestamp", "17"},
                                                                     {"builtin:seq", "x"},
                                                                     {"builtin:id", "43"}});
    data_sample s = data_sample::decode(chunk);
    EXPECT_EQ(s.id(), 42);  // a reader takes a key's first occurrence
    EXPECT_EQ(s.timestamp_ms(), 17);
    EXPECT_FALSE(s.seq().has_value());
    EXPECT_EQ(s.payload()[1], std::byte{'b'});
}

TEST(SampleCodec, DecodeKeepsTheChunkWithoutCopyingThePayload) {
    std::string chunk = encode_chunk(bytes_view(std::string(1000, 'z')), {});
    data_sample s = data_sample::decode(std::move(chunk));
    EXPECT_EQ(s.payload().data(), reinterpret_cast<const std::byte*>(s.chunk().data()) + 4);
    EXPECT_EQ(s.payload().size(), 1000u);
}

TEST(SampleCodec, BytesViewFromVector) {
    std::vector<std::byte> bytes{std::byte{1}, std::byte{0}, std::byte{255}};
    bytes_view v = bytes;
    EXPECT_EQ(v.size(), 3u);
    EXPECT_EQ(v.data(), bytes.data());
    EXPECT_EQ(v.to_vector(), bytes);
}

// -- the stream wire helpers (stream_wire.hpp), without sockets ------------------------------

TEST(StreamWire, WaitTypeCarriesTheTimeout) {
    EXPECT_EQ(detail::wait_type(true, false, 500), "WAIT_FOR_FIRST_AFTERID 500");
    EXPECT_EQ(detail::wait_type(false, true, 0), "WAIT_FOR_LAST_SAMPLE 0");
    EXPECT_THROW((void)detail::wait_type(true, true, -1), error);
}

TEST(StreamWire, TimeAndRangeContent) {
    EXPECT_EQ(detail::time_content(1795328400120), R"(<time sec="1795328400" msec="120"/>)");
    EXPECT_EQ(detail::range_content(1000, 2000),
              R"(<objectcollection><object><time sec="1" msec="0"/></object>)"
              R"(<object><time sec="2" msec="0"/></object></objectcollection>)");
}

TEST(StreamWire, SearchContent) {
    sample_search q;
    q.after_ms = 1000;
    q.params = {{"camera", "left*"}};
    q.latest = 2;
    EXPECT_EQ(detail::search_content(q),
              "<samplesearch><afterTime>1000</afterTime><param name=\"camera\">left*</param>"
              "<latest>2</latest></samplesearch>");
}

TEST(StreamWire, IdsOfAnAddSamplesReply) {
    EXPECT_EQ(detail::ids_of("<collection><entry>4</entry><entry> 5 </entry></collection>"),
              (std::vector<std::uint64_t>{4, 5}));
    EXPECT_THROW((void)detail::ids_of("<collection><entry>x</entry></collection>"), error);
    EXPECT_THROW((void)detail::ids_of("<other/>"), error);
}

TEST(StreamWire, StreamInfo) {
    stream_info i = detail::stream_info_of(
        R"(<streaminfo name="S" whiteboard="WB1" count="3" size="9" oldest="40" newest="42" )"
        R"(maxsize="10485760" maxcount="0" subscribers="2" writers="1" locked="1"/>)");
    EXPECT_EQ(i.name, "S");
    EXPECT_EQ(i.count, 3u);
    EXPECT_EQ(i.oldest, 40u);
    EXPECT_EQ(i.subscribers, 2u);
    EXPECT_EQ(i.locked, 1u);
    EXPECT_FALSE(i.softsize.has_value());
    EXPECT_THROW((void)detail::stream_info_of(R"(<streaminfo count="3"/>)"), error);
    EXPECT_THROW((void)detail::stream_info_of(R"(<streaminfo name="S" count="x"/>)"), error);
}

TEST(StreamWire, StreamList) {
    auto list = detail::stream_list_of(
        R"(<streams><streaminfo name="A"/><streaminfo name="B"/></streams>)");
    ASSERT_EQ(list.size(), 2u);
    EXPECT_EQ(list[1].name, "B");
    EXPECT_TRUE(detail::stream_list_of("").empty());
    EXPECT_THROW((void)detail::stream_list_of("<streams><other/></streams>"), error);
}

TEST(StreamWire, SamplesOfCountsDatasampleElements) {
    message reply;
    reply.type = "DATASAMPLES";
    reply.content = "<objectcollection><object><datasample/></object></objectcollection>";
    reply.content_is_xml = true;
    reply.binary = {encode_chunk(bytes_view(std::string("p")), {})};
    EXPECT_EQ(detail::samples_of(reply).size(), 1u);
    reply.binary.push_back(reply.binary.front());
    EXPECT_THROW((void)detail::samples_of(reply), error);  // two chunks, one element
}

TEST(StreamWire, ReceivedSampleReadsTheDroppedSlot) {
    message pushed;
    pushed.type = "DATASAMPLE";
    pushed.sender = "S";
    pushed.binary = {encode_chunk(bytes_view(std::string("p")), {{"builtin:id", "9"}})};
    pushed.set_extra("dropped", "3");
    received_sample got = detail::received_sample_of(pushed, 5);
    EXPECT_EQ(got.stream, "S");
    EXPECT_EQ(got.dropped, 3u);
    EXPECT_EQ(got.sample.id(), 9);
    pushed.set_extra("dropped", "-1");
    EXPECT_THROW((void)detail::received_sample_of(pushed, 5), error);
}

TEST(StreamWire, AlarmOf) {
    message post;
    post.type = "AIR.Stream.Alarm.Gap";
    post.sender = "Mic1";
    post.content_is_xml = true;
    post.content = R"(<dictionary><entry name="stream">Mic1</entry>)"
                   R"(<entry name="expected">8</entry></dictionary>)";
    stream_alarm a = detail::alarm_of(post);
    EXPECT_EQ(a.kind, "Gap");
    EXPECT_EQ(a.stream, "Mic1");
    EXPECT_EQ(a.entries.at("expected"), "8");
}

}  // namespace
}  // namespace openair
