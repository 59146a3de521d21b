// Content objects: registrations, retrieves, capabilities, retrieve results and wakeups.
#include <gtest/gtest.h>

#include "openair/codec.hpp"
#include "openair/content.hpp"
#include "support.hpp"

namespace openair {
namespace {

message vector_message(const std::string& name) {
    return decode_message(test::read_file(test::vectors_dir() + "/messages/" + name + ".xml"));
}

template <typename F>
errc code_of(F&& f) {
    try {
        f();
    } catch (const error& e) {
        return e.code();
    }
    ADD_FAILURE() << "no error";
    return errc::api_misuse;
}

TEST(Registration, ModuleForm) {
    retrieve_spec data;
    data.whiteboard = "WB1";
    data.type = "TR.Data.*";
    data.latest = 2;
    std::string xml = encode_registration(
        "N1", {trigger{"TR.Go", "WB1", 0, ""}, trigger{"TR.Stop", "", 500, "stop"}}, {data}, true);
    EXPECT_EQ(xml,
              "<module name=\"N1\" allowselftriggering=\"yes\"><triggers>"
              "<trigger type=\"TR.Go\" from=\"WB1\"/>"
              "<trigger type=\"TR.Stop\" after=\"500\" alias=\"stop\"/></triggers>"
              "<retrieves><retrieve from=\"WB1\" type=\"TR.Data.*\"><latest>2</latest></retrieve>"
              "</retrieves></module>");
    EXPECT_EQ(encode_registration("M", {}), "<module name=\"M\"/>");  // OA-REG-11
}

TEST(Registration, InvalidPatternIsRefusedBeforeSending) {
    EXPECT_EQ(code_of([] { (void)encode_registration("M", {trigger{"A.**", "", 0, ""}}); }),
              errc::pattern_invalid);  // OA-MATCH-7
    EXPECT_EQ(code_of([] { (void)encode_registration("M", {trigger{"", "", 0, ""}}); }),
              errc::pattern_invalid);
}

TEST(Retrieve, Encoding) {
    retrieve_spec spec;
    spec.whiteboard = "WB1";
    spec.type = "Ret.A.*";
    spec.latest = 3;
    EXPECT_EQ(encode_retrieve(spec),
              "<retrieve from=\"WB1\" type=\"Ret.A.*\"><latest>3</latest></retrieve>");
    spec.sender = "Poster";
    spec.content = "*tomato*";
    spec.content_match_xml = true;
    spec.lastmsec = 100000;
    spec.after_time = air_time{1795328371, 5, std::nullopt};
    spec.until_time = air_time{1795328372, 6, 7};
    EXPECT_EQ(encode_retrieve(spec),
              "<retrieve from=\"WB1\" type=\"Ret.A.*\" sender=\"Poster\" content=\"*tomato*\" "
              "contentmatch=\"xml\"><latest>3</latest><lastmsec>100000</lastmsec>"
              "<afterTime>1795328371005</afterTime><untilTime><time sec=\"1795328372\" msec=\"6\" "
              "usec=\"7\"/></untilTime></retrieve>");
    EXPECT_EQ(encode_retrieves({retrieve_spec{}, retrieve_spec{}}),
              "<retrieves><retrieve><latest>1</latest></retrieve><retrieve><latest>1</latest>"
              "</retrieve></retrieves>");
    EXPECT_EQ(code_of([] { (void)encode_retrieves({}); }), errc::api_misuse);
}

TEST(Capabilities, SpecExample) {
    capabilities caps = parse_capabilities(
        "<capabilities protocol=\"OpenAIR/1.0\" server=\"openair-kit/0.1.0\">"
        "<extension name=\"noreply\"/><extension name=\"pipelining\"/><extension name=\"future\"/>"
        "<limit name=\"max-in-flight\" value=\"256\"/><other/>"
        "<limit name=\"max-frame-xml\" value=\"16777216\"/></capabilities>");
    EXPECT_EQ(caps.protocol, "OpenAIR/1.0");
    EXPECT_EQ(caps.server, "openair-kit/0.1.0");
    EXPECT_TRUE(caps.has_extension("noreply"));
    EXPECT_TRUE(caps.has_extension("future"));  // kept; the client ignores it (OA-CAP-3)
    EXPECT_FALSE(caps.has_extension("usec"));
    EXPECT_EQ(caps.limit("max-in-flight"), std::optional<std::uint64_t>(256));
    EXPECT_FALSE(caps.limit("max-queue").has_value());
}

TEST(Capabilities, Refusals) {
    EXPECT_EQ(code_of([] { (void)parse_capabilities("<capabilities server=\"x\"/>"); }),
              errc::content_invalid);
    EXPECT_EQ(code_of([] { (void)parse_capabilities("<capabilities protocol=\"p\"/>"); }),
              errc::content_invalid);
    EXPECT_EQ(code_of([] { (void)parse_capabilities("<a/><b/>"); }), errc::content_invalid);
    EXPECT_EQ(code_of([] { (void)parse_capabilities("<capabilities"); }), errc::content_invalid);
    EXPECT_EQ(code_of([] {
                  (void)parse_capabilities(
                      "<capabilities protocol=\"p\" server=\"s\"><limit name=\"x\" value=\"-1\"/>"
                      "</capabilities>");
              }),
              errc::content_invalid);
}

TEST(MessageCollection, PsycloneRetrieveResult) {
    message reply = vector_message("psy-retrieve-success");
    std::vector<message> found = parse_message_collection(reply.content);
    ASSERT_FALSE(found.empty());
    for (const message& m : found) {
        EXPECT_TRUE(m.wbid.has_value());
        EXPECT_FALSE(m.stored.empty());
    }
    EXPECT_TRUE(parse_message_collection("").empty());
    EXPECT_TRUE(parse_message_collection("<objectcollection/>").empty());
    EXPECT_EQ(code_of([] {
                  (void)parse_message_collection(
                      "<objectcollection><object><x/></object></objectcollection>");
              }),
              errc::content_invalid);
    EXPECT_EQ(code_of([] { (void)parse_message_collection("garbage"); }), errc::content_invalid);
}

TEST(Wakeup, TriggerWakeup) {
    wakeup w = parse_wakeup(vector_message("psy-wakeup-trigger"));
    ASSERT_TRUE(w.trigger.has_value());
    EXPECT_EQ(w.trigger->type, "Test.Ping.A");
    EXPECT_EQ(w.trigger->content, "hello ping");
    EXPECT_EQ(w.lasttrigger, "Test.Ping.*");  // OA-WAKE-4
    EXPECT_TRUE(w.retrieved.empty());
    ASSERT_TRUE(w.phase.has_value());
    EXPECT_EQ(w.phase->module, "Reader");
    ASSERT_EQ(w.phase->triggers.size(), 1u);
    EXPECT_EQ(w.phase->triggers[0].from, "WB1");
}

TEST(Wakeup, RetrievedMessagesNewestFirst) {
    wakeup w = parse_wakeup(vector_message("psy-wakeup-retrieved"));
    ASSERT_TRUE(w.trigger.has_value());
    EXPECT_EQ(w.trigger->type, "TR.Go");
    ASSERT_EQ(w.retrieved.size(), 2u);  // OA-WAKE-3
    EXPECT_EQ(w.retrieved[0].type, "TR.Data.3");
    EXPECT_EQ(w.retrieved[1].type, "TR.Data.2");
    EXPECT_EQ(w.lasttrigger, "TR.Go");
}

TEST(Wakeup, CcWakeupHasNoLastTrigger) {
    wakeup w = parse_wakeup(vector_message("psy-wakeup-cc"));
    ASSERT_TRUE(w.trigger.has_value());
    EXPECT_EQ(w.trigger->comment, "CC'ed to Reader");
    EXPECT_EQ(w.lasttrigger, "");
}

TEST(Wakeup, PhaseUpdate) {
    wakeup w = parse_wakeup(vector_message("psy-wakeup-phase"));
    EXPECT_FALSE(w.trigger.has_value());  // OA-WAKE-8
    ASSERT_TRUE(w.phase.has_value());
    EXPECT_EQ(w.phase->name, "Default Phase");
    message empty = make_message(std::string(wakeup_type), "ContextsAndPhases", "Reader");
    EXPECT_FALSE(parse_wakeup(empty).phase.has_value());
}

TEST(Wakeup, Refusals) {
    message m = make_message(std::string(wakeup_type), "WB1", "Reader");
    m.content_is_xml = true;
    m.language = "xml";
    for (const char* content :
         {"<dictionary/>", "<objectdictionary><x/></objectdictionary>",
          "<objectdictionary><object name=\"TriggerMessage\"><phase/></object>"
          "</objectdictionary>",
          "<objectdictionary><object name=\"A\"/><object name=\"A\"/></objectdictionary>",
          "text"}) {
        m.content = content;
        EXPECT_EQ(code_of([&] { (void)parse_wakeup(m); }), errc::content_invalid) << content;
    }
    message other = make_message("Test.A");
    EXPECT_EQ(code_of([&] { (void)parse_wakeup(other); }), errc::content_invalid);
}

}  // namespace
}  // namespace openair
