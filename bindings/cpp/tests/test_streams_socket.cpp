// The stream API against a scripted fake server over real sockets (spec section 11): the
// handle's own connection, ADD_SAMPLE chunks as written, BinaryM, failure replies as the error
// they name, a wait that times out, a push subscription with `dropped`, acknowledgements and
// the end of the push connection.
#include <gtest/gtest.h>

#include <future>

#include "fake_server.hpp"
#include "openair/client.hpp"
#include "openair/datasample.hpp"
#include "openair/stream.hpp"

namespace openair {
namespace {

using test::fake_server;
using test::peer;
using namespace std::chrono_literals;

/// GET_CAPABILITIES (pipelining, window 4) and a plain, unbound client.
void handshake(peer& primary) {
    message ask = primary.expect("GET_CAPABILITIES");
    message caps = ask.reply("CAPABILITIES", "CNS");
    caps.content =
        "<capabilities protocol=\"OpenAIR/1.0\" server=\"fake/1\"><extension name=\"pipelining\"/>"
        "<limit name=\"max-in-flight\" value=\"4\"/></capabilities>";
    caps.content_is_xml = true;
    caps.language = "xml";
    primary.send(caps);
}

client_options options_for(const fake_server& server) {
    client_options o;
    o.port = server.port();
    o.name = "Mod";
    o.bind = false;
    o.request_timeout = 5000ms;
    o.reconnect = false;
    return o;
}

/// Answer the GET_NAME that opens a handle's connection.
void named(peer& conn, const std::string& name) {
    message ask = conn.expect("GET_NAME");
    if (ask.to != name) throw std::runtime_error("GET_NAME to " + ask.to);
    conn.reply(ask, "NAME", name, name);
}

void expect_chunk(const message& m, const std::string& chunk) {
    if (m.binary.size() != 1 || m.binary.front() != chunk) {
        throw std::runtime_error(m.type + ": the chunk is not as written");
    }
}

message sample_reply(const message& request, const std::string& type, const std::string& chunk) {
    message r = request.reply(type, "Cam");
    r.content = "<datasample/>";
    r.content_is_xml = true;
    r.language = "xml";
    r.binary = {chunk};
    return r;
}

TEST(StreamsSocket, WriteReadAndFailures) {
    fake_server server;
    const std::string payload("\x00\x01\xff", 3);
    const std::string written =
        encode_chunk(bytes_view(payload), {{"camera", "left"}, {"builtin:timestamp", "5"}});
    auto script = std::async(std::launch::async, [&] {
        peer primary = server.accept();
        handshake(primary);
        peer conn = server.accept();  // the handle's own connection
        named(conn, "Cam");
        message add = conn.expect("ADD_SAMPLE");
        expect_chunk(add, written);  // OA-STREAM-2: the writer's parameters first
        conn.reply(add, "DATA_ACCEPTED", "7", "Cam");
        frame bin = conn.read_frame();  // OA-STREAM-11: a bare BinaryM frame
        if (bin.tag != frame_tag::binary || bin.chunks.front() != written)
            throw std::runtime_error("not the BinaryM frame written");
        message accepted = make_message("DATA_ACCEPTED", "Cam", "");
        accepted.content = "8";
        conn.send(accepted);  // empty isresponse (OA-STREAM-11)
        message many = conn.expect("ADD_SAMPLES");
        if (many.binary.size() != 2) throw std::runtime_error("ADD_SAMPLES without two chunks");
        message ids = many.reply("DATA_ACCEPTED", "Cam");
        ids.content = "<collection><entry>9</entry><entry>10</entry></collection>";
        ids.content_is_xml = true;
        conn.send(ids);
        message get = conn.expect("GET_SAMPLE_BY_ID");
        std::string held = encode_chunk(bytes_view(payload), {{"builtin:id", "7"}});
        conn.send(sample_reply(get, "DATASAMPLE", held));
        message big = conn.expect("ADD_SAMPLE");
        conn.reply(big, "DATA_NOT_ACCEPTED", "SAMPLE_INVALID: larger than the byte limit", "Cam");
        message wait = conn.expect("WAIT_FOR_FIRST_AFTERID 20");
        conn.reply(wait, "RECEIVE_ERROR", "SAMPLE_UNKNOWN: the timeout passed", "Cam");
        message missing = conn.expect("GET_SAMPLE_BY_ID");
        conn.reply(missing, "RECEIVE_ERROR", "SAMPLE_UNKNOWN: no sample 99", "Cam");
        return std::string("ok");
    });
    client c = client::connect(options_for(server));
    openair::stream& cam = c.stream("Cam");
    sample_options o;
    o.params = {{"camera", "left"}};
    o.timestamp_ms = 5;
    EXPECT_EQ(cam.add(bytes_view(payload), o), 7u);
    EXPECT_EQ(cam.add_binary(bytes_view(payload), o), 8u);
    std::vector<std::byte> one{std::byte{1}}, two{std::byte{2}};
    EXPECT_EQ(cam.add_many({one, two}), (std::vector<std::uint64_t>{9, 10}));
    data_sample got = cam.get(7);
    EXPECT_EQ(std::string(got.payload().chars()), payload);
    EXPECT_EQ(got.id(), 7);
    try {
        (void)cam.add(bytes_view(payload));
        ADD_FAILURE() << "DATA_NOT_ACCEPTED must throw";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::sample_invalid);  // the condition the reply names (OA-ERR-2)
    }
    EXPECT_FALSE(cam.wait_after_id(7, 20ms).has_value());  // OA-STREAM-7: a timeout, no error
    try {
        (void)cam.get(99);
        ADD_FAILURE() << "RECEIVE_ERROR must throw";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::sample_unknown);
    }
    EXPECT_EQ(script.get(), "ok");
}

message info_reply(const message& ask, int subscribers) {
    message r = ask.reply("INFO", "Cam");
    r.content = "<streaminfo name=\"Cam\" whiteboard=\"WB1\" count=\"0\" size=\"0\" maxsize=\"1\" "
                "maxcount=\"0\" subscribers=\"" +
                std::to_string(subscribers) + "\" writers=\"0\" locked=\"0\"/>";
    r.content_is_xml = true;
    return r;
}

TEST(StreamsSocket, PushSubscriptionReceivesAcknowledgesAndEnds) {
    fake_server server;
    auto script = std::async(std::launch::async, [&] {
        peer primary = server.accept();
        handshake(primary);
        peer conn = server.accept();
        named(conn, "Cam");
        conn.send(info_reply(conn.expect("GET_INFO"), 0));
        peer push = server.accept();
        frame note = push.read_frame();  // OA-STREAM-8: Receive, RECEIVE_NAME_NOTIFICATION
        message n = from_frame(note);
        if (note.tag != frame_tag::receive || n.type != "RECEIVE_NAME_NOTIFICATION" ||
            n.to != "Cam") {
            throw std::runtime_error("not a push notification");
        }
        conn.send(info_reply(conn.expect("GET_INFO"), 1));
        message pushed = make_message("DATASAMPLE", "Cam", "Mod");
        pushed.content = "<datasample/>";
        pushed.content_is_xml = true;
        pushed.binary = {encode_chunk(bytes_view(std::string("px")), {{"builtin:id", "4"}})};
        pushed.set_extra("dropped", "2");
        push.send(pushed);
        message ack = push.expect("RECEIVE_ACCEPT");  // OA-STREAM-12, OA-DELIV-4
        if (ack.isresponse != pushed.id) throw std::runtime_error("ack not paired");
        push.close();  // the server drops the push connection
        return std::string("ok");
    });
    client c = client::connect(options_for(server));
    stream_subscription& sub = c.subscribe_stream("Cam");
    std::optional<received_sample> got = sub.next(5s);
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(got->stream, "Cam");
    EXPECT_EQ(got->dropped, 2u);
    EXPECT_EQ(got->sample.id(), 4);
    EXPECT_EQ(script.get(), "ok");
    try {
        while (sub.next(5s)) {
        }
        ADD_FAILURE() << "the end of the push connection must be reported";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);
    }
    EXPECT_FALSE(sub.active());
    EXPECT_EQ(sub.received(), 1u);
    EXPECT_EQ(sub.dropped(), 2u);
}

}  // namespace
}  // namespace openair
