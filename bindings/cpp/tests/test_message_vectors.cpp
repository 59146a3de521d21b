// Every case of spec/vectors/messages: decoded fields or error, and the canonical bytes.
#include <gtest/gtest.h>

#include "openair/codec.hpp"
#include "support.hpp"

namespace openair {
namespace {

struct message_case {
    std::string name;
    json::value spec;
};

std::vector<message_case> load_cases(bool valid) {
    std::vector<message_case> out;
    json::value manifest = test::load_manifest("messages/manifest.json");
    for (const json::value& c : manifest.at("cases").as_array()) {
        if ((c.at("expected").find("fields") != nullptr) == valid) {
            out.push_back({c.at("name").as_string(), c});
        }
    }
    return out;
}

// gtest prints parameters in failure messages and test names: the case name says it all.
void PrintTo(const message_case& c, std::ostream* os) {
    *os << c.name;
}

std::string case_name(const testing::TestParamInfo<message_case>& info) {
    std::string name = info.param.name;
    for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    }
    return name;
}

std::string source(const json::value& c) {
    return test::read_file(test::vectors_dir() + "/messages/" + c.at("file").as_string());
}

std::vector<std::string> chunks(const json::value& c) {
    std::vector<std::string> out;
    if (const json::value* list = c.find("chunks")) {
        for (const json::value& h : list->as_array()) out.push_back(test::from_hex(h.as_string()));
    }
    return out;
}

void expect_time(const std::optional<air_time>& got, const json::value& want) {
    if (want.is_null()) {
        EXPECT_FALSE(got.has_value());
        return;
    }
    ASSERT_TRUE(got.has_value());
    const json::array& parts = want.as_array();
    EXPECT_EQ(got->sec, parts.at(0).as_int());
    EXPECT_EQ(got->msec, parts.at(1).as_int());
    if (parts.size() > 2) {
        EXPECT_EQ(got->usec, std::optional<int>(static_cast<int>(parts[2].as_int())));
    } else {
        EXPECT_FALSE(got->usec.has_value());
    }
}

void expect_number(const std::optional<double>& got, const json::value& want) {
    if (want.is_null()) {
        EXPECT_FALSE(got.has_value());
    } else {
        ASSERT_TRUE(got.has_value());
        EXPECT_EQ(*got, want.as_double());
    }
}

const std::string* text_field(const message& m, const std::string& key) {
    if (key == "type") return &m.type;
    if (key == "id") return &m.id;
    if (key == "sender") return &m.sender;
    if (key == "to") return &m.to;
    if (key == "cc") return &m.cc;
    if (key == "stored") return &m.stored;
    if (key == "isresponse") return &m.isresponse;
    if (key == "comment") return &m.comment;
    if (key == "netprotocol") return &m.netprotocol;
    if (key == "language") return &m.language;
    if (key == "content") return &m.content;
    if (key == "history") return &m.history;
    return nullptr;
}

void expect_inreplyto(const std::optional<reference>& got, const json::value& want) {
    if (want.is_null()) {
        EXPECT_FALSE(got.has_value());
        return;
    }
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(got->id, want.at("id").as_string());
    EXPECT_EQ(got->type, want.at("type").as_string());
    EXPECT_EQ(got->sender, want.at("from").as_string());
    EXPECT_EQ(got->to, want.at("to").as_string());
    EXPECT_EQ(got->cc, want.at("cc").as_string());
    EXPECT_EQ(got->stored, want.at("stored").as_string());
    expect_time(got->time, want.at("time"));
}

void expect_fields(const message& m, const json::value& fields) {
    for (const auto& [key, want] : fields.as_object()) {
        SCOPED_TRACE("field " + key);
        if (const std::string* text = text_field(m, key)) {
            EXPECT_EQ(*text, want.as_string());
        } else if (key == "posted") {
            expect_time(m.posted, want);
        } else if (key == "received") {
            expect_time(m.received, want);
        } else if (key == "inreplyto") {
            expect_inreplyto(m.inreplyto, want);
        } else if (key == "priority") {
            expect_number(m.priority, want);
        } else if (key == "timetolive") {
            expect_number(m.timetolive, want);
        } else if (key == "noreply") {
            EXPECT_EQ(m.noreply, want.as_bool());
        } else if (key == "content_is_xml") {
            EXPECT_EQ(m.content_is_xml, want.as_bool());
        } else if (key == "wbid") {
            if (want.is_null()) {
                EXPECT_FALSE(m.wbid.has_value());
            } else {
                EXPECT_EQ(m.wbid, std::optional<std::uint64_t>(want.as_int()));
            }
        } else if (key == "extras") {
            const json::array& list = want.as_array();
            ASSERT_EQ(m.extras.size(), list.size());
            for (std::size_t i = 0; i < list.size(); ++i) {
                EXPECT_EQ(m.extras[i].name, list[i].as_array().at(0).as_string());
                EXPECT_EQ(m.extras[i].value, list[i].as_array().at(1).as_string());
                EXPECT_EQ(m.extras[i].is_xml, list[i].as_array().at(2).as_bool());
            }
        } else if (key == "binary") {
            const json::array& list = want.as_array();
            ASSERT_EQ(m.binary.size(), list.size());
            for (std::size_t i = 0; i < list.size(); ++i) {
                EXPECT_EQ(test::to_hex(m.binary[i]), list[i].as_string());
            }
        } else {
            ADD_FAILURE() << "the test does not know the manifest field " << key;
        }
    }
}

class ValidMessages : public testing::TestWithParam<message_case> {};
class InvalidMessages : public testing::TestWithParam<message_case> {};

TEST_P(ValidMessages, DecodeGivesFields) {
    const json::value& c = GetParam().spec;
    message m = decode_message(source(c), chunks(c));
    expect_fields(m, c.at("expected").at("fields"));
    if (const json::value* nested = c.at("expected").find("nested")) {
        ASSERT_TRUE(m.content_is_xml);
        std::optional<message> inner = find_message(m.content);
        ASSERT_TRUE(inner.has_value());
        expect_fields(*inner, *nested);
    }
}

TEST_P(ValidMessages, EncodeGivesCanonicalBytes) {
    const json::value& c = GetParam().spec;
    std::string canonical =
        test::read_file(test::vectors_dir() + "/messages/" + c.at("canonical").as_string());
    message m = decode_message(source(c), chunks(c));
    EXPECT_EQ(encode_message(m), canonical);
    message again = decode_message(canonical, chunks(c));
    EXPECT_TRUE(again == m);
    EXPECT_EQ(encode_message(again), canonical);
}

TEST_P(ValidMessages, FrameRoundTrip) {
    const json::value& c = GetParam().spec;
    message m = decode_message(source(c), chunks(c));
    frame_reader reader;
    reader.feed(encode_frame(to_frame(m)));
    std::optional<frame> f = reader.next();
    ASSERT_TRUE(f.has_value());
    EXPECT_TRUE(from_frame(*f) == m);
    EXPECT_FALSE(reader.next().has_value());
}

TEST_P(InvalidMessages, DecodeGivesError) {
    const json::value& c = GetParam().spec;
    const std::string& want = c.at("expected").at("error").as_string();
    try {
        (void)decode_message(source(c), chunks(c));
        ADD_FAILURE() << "decoding must fail with " << want;
    } catch (const error& e) {
        EXPECT_EQ(errc_name(e.code()), want) << e.what();
        EXPECT_FALSE(e.detail().empty());  // every error says what was wrong
        EXPECT_EQ(e.blame(), blame::remote);
    }
}

// spec/vectors/legacy: what Psyclone 1.1.7 writes, read as a client reads it (OA-MSG-19).
std::vector<message_case> load_legacy_cases() {
    std::vector<message_case> out;
    json::value manifest = test::load_manifest("legacy/manifest.json");
    for (const json::value& c : manifest.at("cases").as_array()) {
        out.push_back({c.at("name").as_string(), c});
    }
    return out;
}

std::string legacy_source(const json::value& c) {
    return test::read_file(test::vectors_dir() + "/legacy/" + c.at("file").as_string());
}

class LegacyMessages : public testing::TestWithParam<message_case> {};

TEST_P(LegacyMessages, ClientReadingGivesFields) {
    const json::value& c = GetParam().spec;
    message m = decode_message(legacy_source(c), {}, {}, true);
    expect_fields(m, c.at("expected").at("fields"));
    if (const json::value* nested = c.at("expected").find("nested")) {
        ASSERT_TRUE(m.content_is_xml);
        std::optional<message> inner = find_message(m.content);  // always read liberally
        ASSERT_TRUE(inner.has_value());
        expect_fields(*inner, *nested);
    }
    // A writer stays strict: what was read is written back in range and reads back the same.
    EXPECT_TRUE(decode_message(encode_message(m)) == m);
}

TEST_P(LegacyMessages, StrictReadingOfAPost) {
    const json::value& c = GetParam().spec;
    const json::value* strict = c.find("strict");
    if (strict == nullptr) {
        EXPECT_TRUE(decode_message(legacy_source(c)) ==
                    decode_message(legacy_source(c), {}, {}, true));
        return;
    }
    try {
        (void)decode_message(legacy_source(c));
        ADD_FAILURE() << "a server must refuse it";
    } catch (const error& e) {
        EXPECT_EQ(errc_name(e.code()), strict->at("error").as_string()) << e.what();
        EXPECT_NE(e.detail().find("priority"), std::string::npos) << e.detail();
    }
}

INSTANTIATE_TEST_SUITE_P(Legacy, LegacyMessages, testing::ValuesIn(load_legacy_cases()),
                         case_name);

INSTANTIATE_TEST_SUITE_P(Manifest, ValidMessages, testing::ValuesIn(load_cases(true)), case_name);
INSTANTIATE_TEST_SUITE_P(Manifest, InvalidMessages, testing::ValuesIn(load_cases(false)),
                         case_name);

}  // namespace
}  // namespace openair
