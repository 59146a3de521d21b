// The codec beyond the vectors: hostile and corrupt input, writer refusals, frame limits.
#include <gtest/gtest.h>

#include <random>

#include "openair/codec.hpp"
#include "support.hpp"
#include "xml.hpp"

namespace openair {
namespace {

std::vector<std::string> valid_sources() {
    std::vector<std::string> out;
    json::value manifest = test::load_manifest("messages/manifest.json");
    for (const json::value& c : manifest.at("cases").as_array()) {
        if (c.at("expected").find("fields") != nullptr) {
            out.push_back(
                test::read_file(test::vectors_dir() + "/messages/" + c.at("file").as_string()));
        }
    }
    return out;
}

/// Decoding never fails with anything but a condition of the error table.
void decode_or_condition(const std::string& xml) {
    try {
        message m = decode_message(xml);
        (void)encode_message(m);  // what decodes can be written back
    } catch (const error& e) {
        EXPECT_EQ(e.blame(), blame::remote) << e.what();
    }
}

TEST(CorruptInput, EveryTruncationOfEveryValidMessage) {
    for (const std::string& xml : valid_sources()) {
        for (std::size_t cut = 0; cut < xml.size(); cut += 7)
            decode_or_condition(xml.substr(0, cut));
    }
}

TEST(CorruptInput, RandomByteFlips) {
    std::mt19937 gen(20261122);
    for (const std::string& xml : valid_sources()) {
        for (int round = 0; round < 40; ++round) {
            std::string bad = xml;
            std::uniform_int_distribution<std::size_t> at(0, bad.size() - 1);
            std::uniform_int_distribution<int> byte(0, 255);
            for (int k = 0; k < 3; ++k) bad[at(gen)] = static_cast<char>(byte(gen));
            decode_or_condition(bad);
        }
    }
}

TEST(CorruptInput, FrameReaderSurvivesGarbage) {
    std::mt19937 gen(7);
    std::uniform_int_distribution<int> byte(0, 255);
    for (int round = 0; round < 200; ++round) {
        std::string data = round % 2 == 0 ? std::string("Message\0", 8) : std::string();
        for (int k = 0; k < 64; ++k) data += static_cast<char>(byte(gen));
        frame_reader reader(frame_limits{1024, 1024});
        try {
            reader.feed(data);
            while (reader.next()) {
            }
            reader.feed_eof();
            while (reader.next()) {
            }
        } catch (const error& e) {
            EXPECT_TRUE(e.closes() || e.code() == errc::frame_truncated) << e.what();
        }
    }
}

TEST(Hardening, DoctypeAnywhereIsForbidden) {
    for (const char* xml : {"<!DOCTYPE message><message><type>A</type></message>",
                            "<message><type>A</type><!-- x --><! doctype x></message>",
                            "<!ENTITY x 'y'><message/>"}) {
        try {
            (void)decode_message(xml);
            ADD_FAILURE() << xml;
        } catch (const error& e) {
            EXPECT_EQ(e.code(), errc::xml_forbidden) << xml;
        }
    }
}

TEST(Hardening, DepthLimitIsConfigurable) {
    std::string xml = "<message><type>A</type><x><y><z/></y></x></message>";
    EXPECT_NO_THROW((void)decode_message(xml, {}, xml_limits{1 << 20, 4}));
    try {
        (void)decode_message(xml, {}, xml_limits{1 << 20, 3});
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::xml_too_deep);
    }
}

TEST(Hardening, VeryDeepDocumentIsRefusedWithoutCrashing) {
    std::string xml = "<message>";
    for (int i = 0; i < 100000; ++i) xml += "<a>";
    for (int i = 0; i < 100000; ++i) xml += "</a>";
    xml += "</message>";
    try {
        (void)decode_message(xml);
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_TRUE(e.code() == errc::xml_too_deep || e.code() == errc::xml_malformed) << e.what();
    }
}

TEST(Hardening, SizeLimit) {
    try {
        (void)decode_message("<message><type>A</type></message>", {}, xml_limits{10, 64});
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::xml_malformed);
    }
}

TEST(Writer, RefusesWhatXmlCannotCarry) {
    message m = make_message("Test.A", "P", "WB1");
    auto refused = [](const message& bad) {
        try {
            (void)encode_message(bad);
            return false;
        } catch (const error& e) {
            return e.code() == errc::api_misuse && e.blame() == blame::local;
        }
    };
    message nul = m;
    nul.content = std::string("a\0b", 3);  // OA-MSG-14
    EXPECT_TRUE(refused(nul));
    message bad_utf8 = m;
    bad_utf8.sender = "\xff";
    EXPECT_TRUE(refused(bad_utf8));
    message no_type = m;
    no_type.type.clear();
    EXPECT_TRUE(refused(no_type));
    message priority = m;
    priority.priority = 7.0;  // OA-MSG-6
    EXPECT_TRUE(refused(priority));
    message xml = m;
    xml.content_is_xml = true;
    xml.content = "<a>";
    EXPECT_TRUE(refused(xml));
    message doctype = m;
    doctype.content_is_xml = true;
    doctype.content = "<!DOCTYPE a><a/>";
    EXPECT_TRUE(refused(doctype));
    message shadow = m;
    shadow.extras.push_back({"Type", "x", false});
    EXPECT_TRUE(refused(shadow));
    message bad_name = m;
    bad_name.extras.push_back({"1x", "x", false});
    EXPECT_TRUE(refused(bad_name));
    message text_as_xml = m;
    text_as_xml.language = "XML";
    EXPECT_TRUE(refused(text_as_xml));
}

TEST(Writer, CanonicalFormOfABuiltMessage) {
    message m;
    m.type = "Test.Ping.A";
    m.id = "id-1";
    m.sender = "Poster";
    m.to = "WB1";
    m.posted = air_time{1795328371, 396, std::nullopt};
    m.priority = 2.0;
    m.content = "a < b & \"c\"\r";
    m.set_extra("extensions", "noreply usec");
    EXPECT_EQ(encode_message(m),
              "<message priority=\"2.0\"><type>Test.Ping.A</type><id>id-1</id><from>Poster</from>"
              "<to>WB1</to><cc/><stored/><isresponse/><postedTime sec=\"1795328371\" msec=\"396\"/>"
              "<content language=\"\">a &lt; b &amp; \"c\"&#13;</content>"
              "<extensions>noreply usec</extensions></message>");
}

TEST(Writer, DecimalsAreShortestWithAFraction) {
    message m = make_message("A");
    for (auto [value, text] : {std::pair{2.0, "2.0"},
                               {0.5, "0.5"},
                               {6.999, "6.999"},
                               {0.00001, "0.00001"},
                               {0.0, "0.0"},
                               {1.1, "1.1"}}) {
        m.priority = value;
        std::string xml = encode_message(m);
        EXPECT_NE(xml.find(std::string("priority=\"") + text + "\""), std::string::npos) << xml;
    }
}

TEST(Writer, TimesAndIds) {
    air_time t = air_time::from_ns(1795328371396250000LL, true);
    EXPECT_EQ(t.sec, 1795328371);
    EXPECT_EQ(t.msec, 396);
    EXPECT_EQ(t.usec, std::optional<int>(250));
    air_time before = air_time::from_ns(-1);
    EXPECT_EQ(before.sec, -1);
    EXPECT_EQ(before.msec, 999);
    std::string a = new_id();
    EXPECT_EQ(a.size(), 36u);
    EXPECT_EQ(a[14], '4');
    EXPECT_NE(a, new_id());
}

TEST(Message, CcNamesAndExtras) {
    message m = make_message("A");
    m.cc = " A ; ;B;C D ";
    EXPECT_EQ(m.cc_names(), (std::vector<std::string>{"A", "B", "C D"}));  // OA-CC-1
    m.set_extra("Extensions", "x");
    m.set_extra("extensions", "y");
    ASSERT_EQ(m.extras.size(), 1u);
    ASSERT_NE(m.extra("EXTENSIONS"), nullptr);
    EXPECT_EQ(m.extra("EXTENSIONS")->value, "y");
    message r = m.reply("RECEIVE_ACCEPT", "WB1");
    EXPECT_EQ(r.isresponse, m.id);
}

TEST(FrameEncoding, HeaderIsTheSpecExample) {
    frame f{frame_tag::message, std::string(288, 'x'), {}};
    std::string bytes = encode_frame(f);
    EXPECT_EQ(test::to_hex(bytes.substr(0, 12)), "4d6573736167650020010000");  // spec 2.1
    EXPECT_THROW((void)encode_frame(frame{frame_tag::binary, "x", {"a"}}), error);
}

TEST(FrameReader, SeveralFramesAndChunksOneByteAtATime) {
    message m = make_message("Test.Data", "P", "WB1");
    m.binary = {"abc", "", "de"};
    std::string stream = encode_frame(to_frame(m)) +
                         encode_frame(frame{frame_tag::binary, "", {"xyz"}}) +
                         encode_frame(to_frame(make_message("Test.B"), frame_tag::receive));
    frame_reader reader;
    std::vector<frame> got;
    for (char c : stream) {
        reader.feed(std::string_view(&c, 1));
        while (auto f = reader.next()) got.push_back(*f);
    }
    reader.feed_eof();
    ASSERT_EQ(got.size(), 3u);
    EXPECT_EQ(got[0].chunks, m.binary);
    EXPECT_TRUE(from_frame(got[0]) == m);
    EXPECT_EQ(got[1].tag, frame_tag::binary);
    EXPECT_EQ(got[1].chunks, std::vector<std::string>{"xyz"});
    EXPECT_EQ(got[2].tag, frame_tag::receive);
    EXPECT_THROW((void)from_frame(got[1]), error);
}

TEST(Fragment, TextBetweenElementsIsRefused) {
    EXPECT_NO_THROW((void)detail::parse_fragment("  <a/>\n <b>x</b> "));
    EXPECT_THROW((void)detail::parse_fragment("<a/> text"), error);
    EXPECT_EQ(detail::parse_fragment("").elements.size(), 0u);
}

}  // namespace
}  // namespace openair
