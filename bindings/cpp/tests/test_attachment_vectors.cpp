// The wakeup and retrieve cases of spec/vectors/attachments/manifest.json: a frame's chunks
// handed to the stored copies nested in it, in document order (OA-MSG-21, OA-WAKE-10,
// OA-RET-19). The `message` cases (the content version, OA-MSG-22) are not this binding's yet.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "openair/codec.hpp"
#include "openair/content.hpp"
#include "openair/error.hpp"
#include "support.hpp"

namespace openair {
namespace {

using attached = std::vector<std::pair<std::string, std::vector<std::string>>>;

attached expected_of(const json::value& row) {
    attached out;
    for (const json::value& copy : row.at("expected").at("attachments").as_array()) {
        const json::array& pair = copy.as_array();
        std::vector<std::string> chunks;
        for (const json::value& hex : pair.at(1).as_array()) chunks.push_back(hex.as_string());
        out.emplace_back(pair.at(0).as_string(), std::move(chunks));
    }
    return out;
}

attached found_of(const std::vector<message>& copies) {
    attached out;
    for (const message& m : copies) {
        std::vector<std::string> chunks;
        for (const std::string& chunk : m.binary) chunks.push_back(test::to_hex(chunk));
        out.emplace_back(m.id, std::move(chunks));
    }
    return out;
}

std::vector<message> read_case(const std::string& kind, const message& msg) {
    if (kind == "wakeup") {
        wakeup w = parse_wakeup(msg);
        std::vector<message> copies;
        if (w.trigger) copies.push_back(*w.trigger);
        copies.insert(copies.end(), w.retrieved.begin(), w.retrieved.end());
        return copies;
    }
    return parse_message_collection(msg.content, msg.binary);
}

TEST(AttachmentVectors, WakeupsAndRetrievesGiveEachCopyItsChunks) {
    json::value manifest = test::load_manifest("attachments/manifest.json");
    ASSERT_EQ(manifest.at("format").as_string(), "openair-attachment-vectors/1");
    std::size_t cases = 0;
    for (const json::value& row : manifest.at("cases").as_array()) {
        const std::string& kind = row.at("kind").as_string();
        if (kind != "wakeup" && kind != "retrieve") continue;
        const std::string& name = row.at("name").as_string();
        std::string xml = test::read_file(test::vectors_dir() + "/attachments/" +
                                          row.at("file").as_string());
        std::vector<std::string> chunks;
        if (const json::value* list = row.find("chunks")) {
            for (const json::value& hex : list->as_array()) {
                chunks.push_back(test::from_hex(hex.as_string()));
            }
        }
        const json::value& expected = row.at("expected");
        if (const json::value* code = expected.find("error")) {
            try {
                message msg = decode_message(xml, chunks);
                (void)read_case(kind, msg);
                ADD_FAILURE() << name << ": read, should be " << code->as_string();
            } catch (const error& e) {
                EXPECT_EQ(errc_name(e.code()), code->as_string()) << name << ": " << e.what();
            }
        } else {
            message msg = decode_message(xml, chunks);
            EXPECT_EQ(found_of(read_case(kind, msg)), expected_of(row)) << name;
        }
        ++cases;
    }
    EXPECT_GE(cases, 5u);
}

}  // namespace
}  // namespace openair
