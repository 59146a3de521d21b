// The sans-I/O session: two ends joined back to back (h11's ConnectionPair), no sockets.
#include <gtest/gtest.h>

#include "openair/codec.hpp"
#include "openair/content.hpp"
#include "openair/session.hpp"

namespace openair {
namespace {

constexpr std::int64_t fixed_ns = 1795328371396250123LL;
std::int64_t fixed_clock() {
    return fixed_ns;
}

/// The one event of `events`, which must be a T (a copy: `events` is often a temporary).
template <typename T>
T only(const std::vector<session_event>& events) {
    EXPECT_EQ(events.size(), 1u);
    const T* e = std::get_if<T>(&events.at(0));
    if (e == nullptr) throw std::runtime_error("unexpected event kind");
    return *e;
}

/// Feed `bytes` one byte at a time and collect every event.
std::vector<session_event> trickle(session& s, const std::string& bytes) {
    std::vector<session_event> all;
    for (char c : bytes) {
        for (auto& e : s.receive_data(std::string_view(&c, 1))) all.push_back(std::move(e));
    }
    return all;
}

TEST(Session, RequestAndReplyArePaired) {
    session client(role::requester, fixed_clock, 1, {}, "Reader");
    session server(role::responder, fixed_clock, 1, {}, "CNS");
    outgoing ping = client.send_request(make_message("PING", "Reader", "CNS"));
    EXPECT_EQ(ping.sent.posted, air_time::from_ns(fixed_ns));  // OA-TIME-2
    const auto req = only<request_event>(server.receive_data(ping.bytes));
    EXPECT_EQ(req.msg.type, "PING");
    std::string answer = server.answer(req.seq);
    const auto reply = only<reply_event>(trickle(client, answer));
    EXPECT_EQ(reply.request_id, ping.sent.id);
    EXPECT_EQ(reply.msg.type, "PING_SUCCESS");      // OA-SESS-10
    EXPECT_EQ(reply.msg.isresponse, ping.sent.id);  // OA-SESS-1
    EXPECT_EQ(reply.msg.sender, "CNS");
    EXPECT_EQ(reply.msg.to, "Reader");
    EXPECT_EQ(client.in_flight(), 0u);
}

TEST(Session, WindowBoundsRequestsInFlight) {
    session client(role::requester, fixed_clock, 1);
    (void)client.send_request(make_message("A.B"));
    EXPECT_FALSE(client.can_send());
    try {
        (void)client.send_request(make_message("A.C"));  // OA-SESS-18
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::api_misuse);
    }
    client.set_window(3);  // OA-SESS-17: pipelining
    (void)client.send_request(make_message("A.C"));
    (void)client.send_request(make_message("A.D"));
    EXPECT_EQ(client.in_flight(), 3u);
    EXPECT_FALSE(client.can_send());
}

TEST(Session, PipelinedRepliesComeInOrder) {
    session client(role::requester, fixed_clock, 3);
    session server(role::responder, fixed_clock);
    std::string wire;
    std::vector<std::string> ids;
    for (const char* type : {"T.A", "T.B", "T.C"}) {
        outgoing o = client.send_request(make_message(type));
        wire += o.bytes;
        ids.push_back(o.sent.id);
    }
    std::string answers;
    for (auto& e : server.receive_data(wire))
        answers += server.answer(std::get<request_event>(e).seq);
    auto replies = client.receive_data(answers);
    ASSERT_EQ(replies.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i)
        EXPECT_EQ(std::get<reply_event>(replies[i]).request_id, ids[i]);
}

TEST(Session, ReplyToAnotherRequestIsAStickyFailure) {
    session client(role::requester, fixed_clock);
    outgoing o = client.send_request(make_message("T.A"));
    message wrong = make_message("RECEIVE_ACCEPT", "WB1");
    wrong.isresponse = "someone-else";
    auto events = client.receive_data(encode_frame(to_frame(wrong)));
    const auto failed = only<failed_event>(events);
    EXPECT_EQ(failed.failure.code(), errc::message_invalid);  // OA-SESS-2, OA-SESS-33
    EXPECT_EQ(client.state(), session_state::failed);
    try {
        (void)client.receive_data("more");  // OA-FRAME-9: the same failure every time
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::message_invalid);
    }
    try {
        (void)client.send_request(make_message("T.B"));
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);
    }
}

TEST(Session, EmptyIsresponseIsAccepted) {
    session client(role::requester, fixed_clock);
    outgoing o = client.send_request(make_message("KEEPALIVE"));
    message psyclone = make_message("KEEPALIVESUCCESS", "CNS");  // Psyclone sends no isresponse
    const auto reply = only<reply_event>(client.receive_data(encode_frame(to_frame(psyclone))));
    EXPECT_EQ(reply.request_id, o.sent.id);  // OA-SESS-33
}

TEST(Session, ReplyWithNothingInFlightFails) {
    session client(role::requester, fixed_clock);
    auto events = client.receive_data(encode_frame(to_frame(make_message("RECEIVE_ACCEPT"))));
    EXPECT_EQ(only<failed_event>(events).failure.code(), errc::message_invalid);
}

TEST(Session, UnknownTagFailsTheConnection) {
    session client(role::requester, fixed_clock);
    (void)client.send_request(make_message("T.A"));
    auto events = client.receive_data("GET / HTTP/1.1\r\n");
    EXPECT_EQ(only<failed_event>(events).failure.code(), errc::frame_unknown_tag);  // OA-FRAME-6
}

TEST(Session, ResponderAnswersDeliveriesInOrder) {
    session module(role::responder, fixed_clock, 1, {}, "Reader");
    message wakeup = make_message(std::string(wakeup_type), "WB1", "Reader");
    message ping = make_message("PING", "WB1", "Reader");
    message keepalive = make_message("KEEPALIVE");
    auto events =
        module.receive_data(encode_frame(to_frame(wakeup)) + encode_frame(to_frame(ping)) +
                            encode_frame(to_frame(keepalive)));
    ASSERT_EQ(events.size(), 3u);
    EXPECT_EQ(module.unanswered(), 3u);
    auto seq_of = [&](std::size_t i) { return std::get<request_event>(events[i]).seq; };
    EXPECT_THROW((void)module.answer(seq_of(1)), error);  // OA-SESS-2: the oldest first
    std::vector<std::string> types;
    for (std::size_t i = 0; i < 3; ++i) {
        message reply = decode_message(module.answer(seq_of(i)).substr(frame_header_size));
        types.push_back(reply.type);
        EXPECT_EQ(reply.sender, "Reader");
    }
    EXPECT_EQ(types,
              (std::vector<std::string>{"RECEIVE_ACCEPT", "PING_SUCCESS", "KEEPALIVESUCCESS"}));
    EXPECT_THROW((void)module.send_request(make_message("T.A")), error);  // OA-SESS-28
}

TEST(Session, MalformedRequestIsAnsweredAndTheConnectionStays) {
    session module(role::responder, fixed_clock, 1, {}, "Reader");
    std::string broken = encode_frame(frame{frame_tag::message, "<message><type>X</t", {}});
    auto events = module.receive_data(broken);
    const auto bad = only<invalid_event>(events);
    EXPECT_EQ(bad.failure.code(), errc::xml_malformed);
    message reply = decode_message(module.answer(bad.seq).substr(frame_header_size));
    EXPECT_EQ(reply.type, "RECEIVE_ERROR");                    // OA-ERR-3
    EXPECT_EQ(reply.content.rfind("XML_MALFORMED: ", 0), 0u);  // OA-ERR-2
    EXPECT_TRUE(reply.isresponse.empty());
    const auto next =
        only<request_event>(module.receive_data(encode_frame(to_frame(make_message("PING")))));
    EXPECT_EQ(next.msg.type, "PING");
}

TEST(Session, NotificationTurnsTheConnectionAround) {
    session callback(role::requester, fixed_clock, 1, {}, "Reader");
    outgoing note = callback.send_notification(make_message("RECEIVE_NAME_NOTIFICATION", "Reader"));
    EXPECT_EQ(note.bytes.substr(0, 8), std::string("Receive\0", 8));  // OA-FRAME-10
    EXPECT_EQ(callback.state(), session_state::responder);            // OA-SESS-7
    const auto req =
        only<request_event>(callback.receive_data(encode_frame(to_frame(make_message("PING")))));
    EXPECT_NO_THROW((void)callback.answer(req.seq));
    session busy(role::requester, fixed_clock);
    (void)busy.send_request(make_message("T.A"));
    EXPECT_THROW((void)busy.send_notification(make_message("RECEIVE_NAME_NOTIFICATION")), error);
}

TEST(Session, NoreplyNeedsTheExtension) {
    message post = make_message("T.A", "P", "WB1");
    post.noreply = true;
    session legacy(role::requester, fixed_clock);
    EXPECT_THROW((void)legacy.send_request(post), error);  // OA-GEN-2
    session modern(role::requester, fixed_clock, 1, {"noreply"});
    outgoing o = modern.send_request(post);
    EXPECT_EQ(modern.in_flight(), 0u);  // OA-MSG-15: no reply comes
    EXPECT_TRUE(modern.can_send());
    session module(role::responder, fixed_clock, 1, {"noreply"});
    const auto req = only<request_event>(module.receive_data(o.bytes));
    EXPECT_FALSE(req.needs_answer);
    EXPECT_EQ(module.unanswered(), 0u);
}

TEST(Session, EndOfStream) {
    session client(role::requester, fixed_clock);
    outgoing o = client.send_request(make_message("T.A"));
    const auto closed = only<closed_event>(client.receive_eof());
    EXPECT_EQ(closed.unanswered, std::vector<std::string>{o.sent.id});
    EXPECT_THROW((void)client.send_request(make_message("T.B")), error);

    session cut(role::requester, fixed_clock);
    (void)cut.send_request(make_message("T.A"));
    (void)cut.receive_data(std::string("Message\0\x10\0\0\0<mess", 17));
    EXPECT_EQ(only<failed_event>(cut.receive_eof()).failure.code(),
              errc::frame_truncated);  // OA-FRAME-8
}

TEST(Session, UsecOnlyUnderTheExtension) {
    session plain(role::requester, fixed_clock);
    EXPECT_FALSE(plain.send_request(make_message("T.A")).sent.posted->usec.has_value());
    session usec(role::requester, fixed_clock, 1, {"usec"});
    EXPECT_EQ(usec.send_request(make_message("T.A")).sent.posted->usec, std::optional<int>(250));
}

TEST(Session, DefaultAnswers) {
    EXPECT_EQ(default_answer("PING"), "PING_SUCCESS");
    EXPECT_EQ(default_answer("KEEPALIVE"), "KEEPALIVESUCCESS");
    EXPECT_EQ(default_answer("AIR.Instruct.Wakeup"), "RECEIVE_ACCEPT");
    EXPECT_EQ(client_extensions().count("noreply"), 1u);
    EXPECT_EQ(client_extensions().count("auth"), 0u);  // OA-EXT-4
}

}  // namespace
}  // namespace openair
