// The client against a scripted fake server over real sockets (spec sections 6-9, 15).
#include <gtest/gtest.h>

#include <future>

#include "fake_server.hpp"
#include "openair/client.hpp"
#include "openair/content.hpp"
#include "support.hpp"

namespace openair {
namespace {

using test::fake_server;
using test::peer;
using namespace std::chrono_literals;

const char* modern_caps =
    "<capabilities protocol=\"OpenAIR/1.0\" server=\"fake/1\"><extension name=\"noreply\"/>"
    "<extension name=\"pipelining\"/><extension name=\"unknown-one\"/>"
    "<limit name=\"max-in-flight\" value=\"4\"/></capabilities>";

void send_capabilities(peer& p, const message& ask, bool legacy) {
    if (legacy) {
        p.reply(ask, "UNKNOWN_COMMAND", "Offending cmd: GET_CAPABILITIES");  // OA-CAP-2
        return;
    }
    message caps = ask.reply("CAPABILITIES", "CNS");
    caps.content = modern_caps;
    caps.content_is_xml = true;
    caps.language = "xml";
    p.send(caps);
}

/// Serve GET_CAPABILITIES, BIND_NOLISTEN, the callback connection and the announcement.
peer handshake_nolisten(fake_server& server, peer& primary, bool legacy,
                        const char* announce = "Connect") {
    send_capabilities(primary, primary.expect("GET_CAPABILITIES"), legacy);
    message bind = primary.expect("BIND_NOLISTEN");
    if (legacy != (bind.extra("extensions") == nullptr)) {  // OA-GEN-2, OA-SESS-19
        throw std::runtime_error("extensions slot sent to the wrong kind of server");
    }
    primary.reply(bind, "BIND_ACCEPT", "-1");  // OA-SESS-5
    peer callback = server.accept();
    frame note = callback.read_frame();
    if (note.tag != frame_tag::receive)
        throw std::runtime_error("callback without a Receive frame");
    if (from_frame(note).type != "RECEIVE_NAME_NOTIFICATION")
        throw std::runtime_error("bad notification");
    message hello = primary.read();
    if (hello.type != std::string("Psyclone.Module.") + announce + ".Mod") {
        throw std::runtime_error("unexpected announcement " + hello.type);
    }
    primary.reply(hello, "RECEIVE_ACCEPT", "", "AIRCentral");
    return callback;
}

client_options options_for(const fake_server& server) {
    client_options o;
    o.port = server.port();
    o.name = "Mod";
    o.listen = false;
    o.request_timeout = 5000ms;
    o.reconnect = false;
    return o;
}

message wakeup_for(const std::string& type, const std::string& content) {
    message stored = make_message(type, "Poster", "WB1");
    stored.stored = "WB1";
    stored.content = content;
    stored.posted = air_time{1795328371, 396, std::nullopt};
    stored.received = air_time{1795328371, 444, std::nullopt};
    stored.wbid = 17;
    message w = make_message(std::string(wakeup_type), "WB1", "Mod");
    w.stored = "WB1";
    w.language = "xml";
    w.content_is_xml = true;
    w.content = "<objectdictionary><object name=\"TriggerMessage\">" + encode_message(stored) +
                "</object><object name=\"RetrievedMessages\"><objectcollection/></object>"
                "<object name=\"PhaseSpec\"><phase name=\"Default\" module=\"Mod\" "
                "context=\"Psyclone.System.Ready\" lasttrigger=\"Test.*\"><triggers>"
                "<trigger after=\"0\" from=\"WB1\" type=\"Test.*\"/></triggers></phase></object>"
                "</objectdictionary>";
    return w;
}

/// Poll until `done` or 5 s passed.
template <typename P>
void poll_until(client& c, P done) {
    auto deadline = std::chrono::steady_clock::now() + 5s;
    while (!done() && std::chrono::steady_clock::now() < deadline) c.poll(50ms);
}

TEST(ClientSocket, ModernServerSessionWithCallbackDeliveries) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        peer callback = handshake_nolisten(server, primary, false);
        message sub = primary.expect("AIR.Subscribe");  // OA-REG-3: the module form
        if (sub.to != "AIRCentral" || sub.content.find("<module name=\"Mod\">") != 0) {
            throw std::runtime_error("unexpected registration " + sub.content);
        }
        primary.reply(sub, "RECEIVE_ACCEPT", "", "AIRCentral");
        message post = primary.expect("Test.Ping.A");
        if (!post.posted || post.cc != "A;B" || post.priority != std::optional<double>(1.5)) {
            throw std::runtime_error("post slots not as given");
        }
        primary.reply(post, "RECEIVE_ACCEPT", "", "WB1");
        message fast = primary.expect("Test.Fast");
        if (!fast.noreply) throw std::runtime_error("noreply not used although advertised");
        // OA-SESS-17: three requests arrive before any reply is sent.
        std::vector<message> batch = {primary.read(), primary.read(), primary.read()};
        for (const message& m : batch) primary.reply(m, "RECEIVE_ACCEPT", "", "WB1");
        // Deliveries on the callback connection: PING first, then a wakeup.
        message ping = make_message("PING", "WB1", "Mod");
        callback.send(ping);
        message pong = callback.expect("PING_SUCCESS");  // OA-SESS-11
        if (pong.isresponse != ping.id) throw std::runtime_error("PING_SUCCESS not paired");
        message w = wakeup_for("Test.Ping.A", "hello ping");
        callback.send(w);
        message ack = callback.expect("RECEIVE_ACCEPT");  // OA-DELIV-4
        if (ack.isresponse != w.id || ack.sender != "Mod")
            throw std::runtime_error("ack not paired");
        return std::string("ok");
    });
    client c = client::connect(options_for(server));
    EXPECT_FALSE(c.legacy());
    EXPECT_EQ(c.bound_port(), -1);
    EXPECT_EQ(c.extensions(), (std::set<std::string>{"noreply", "pipelining"}));
    std::vector<wakeup_event> seen;
    c.on_wakeup([&seen](const wakeup_event& e) { seen.push_back(e); });
    c.subscribe({trigger{"Test.*", "WB1", 0, ""}});
    post_options po;
    po.cc = {"A", "B"};
    po.priority = 1.5;
    message sent = c.post("WB1", "Test.Ping.A", "hello", po);
    EXPECT_TRUE(sent.posted.has_value());
    (void)c.post_noreply("WB1", "Test.Fast", "f");
    std::vector<message> many;
    for (const char* t : {"Test.P1", "Test.P2", "Test.P3"})
        many.push_back(make_message(t, "", "WB1"));
    EXPECT_EQ(c.post_many(many).size(), 3u);
    poll_until(c, [&seen] { return !seen.empty(); });
    ASSERT_EQ(seen.size(), 1u);
    ASSERT_TRUE(seen[0].wakeup.trigger.has_value());
    EXPECT_EQ(seen[0].wakeup.trigger->content, "hello ping");
    EXPECT_EQ(seen[0].wakeup.lasttrigger, "Test.*");
    EXPECT_EQ(seen[0].path, delivery_path::callback);
    EXPECT_EQ(script.get(), "ok");
}

TEST(ClientSocket, LegacyServerDeliversOnTheListeningPort) {
    fake_server server;
    std::uint16_t module_port = fake_server::free_port();
    auto script = std::async(std::launch::async, [&server, module_port] {
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), true);
        message bind = primary.expect("BIND");
        if (bind.extra("extensions") != nullptr)
            throw std::runtime_error("extensions sent to legacy");
        primary.reply(bind, "BIND_ACCEPT", std::to_string(module_port));  // OA-SESS-3
        peer callback = server.accept();
        (void)callback.read_frame();
        primary.reply(primary.expect("Psyclone.Module.Connect.Mod"), "RECEIVE_ACCEPT");
        message post = primary.expect("Test.Quiet");
        if (post.noreply) throw std::runtime_error("noreply sent to a legacy server");  // OA-GEN-2
        primary.reply(post, "RECEIVE_ACCEPT", "", "WB1");
        peer delivery = fake_server::connect_to(module_port);  // OA-DELIV-2
        message w = wakeup_for("Test.Legacy", "via port");
        delivery.send(w);
        delivery.send(make_message("KEEPALIVE"));
        delivery.expect("RECEIVE_ACCEPT");
        delivery.expect("KEEPALIVESUCCESS");  // OA-KEEP-2, in order (OA-SESS-2)
        message direct = make_message("Some.Note", "Other", "Mod");
        delivery.send(direct);
        delivery.expect("RECEIVE_ACCEPT");  // OA-SESS-22
        // A wakeup that cannot be read is answered RECEIVE_ERROR (OA-SESS-11).
        message broken = make_message(std::string(wakeup_type), "WB1", "Mod");
        broken.content = "not xml";
        delivery.send(broken);
        message err = delivery.expect("RECEIVE_ERROR");
        if (err.content.rfind("CONTENT_INVALID", 0) != 0) throw std::runtime_error(err.content);
        return std::string("ok");
    });
    client_options o = options_for(server);
    o.listen = true;
    client c = client::connect(o);
    EXPECT_TRUE(c.legacy());
    EXPECT_TRUE(c.extensions().empty());
    EXPECT_EQ(c.bound_port(), module_port);
    EXPECT_EQ(c.listen_port(), std::optional<std::uint16_t>(module_port));
    (void)c.post_noreply("WB1", "Test.Quiet");
    std::vector<wakeup_event> wakeups;
    std::vector<message_event> notes;
    c.on_wakeup([&](const wakeup_event& e) { wakeups.push_back(e); });
    c.on_message([&](const message_event& e) { notes.push_back(e); });
    poll_until(c, [&] { return !wakeups.empty() && !notes.empty(); });
    ASSERT_EQ(wakeups.size(), 1u);
    EXPECT_EQ(wakeups[0].path, delivery_path::listener);
    EXPECT_EQ(wakeups[0].wakeup.trigger->type, "Test.Legacy");
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_EQ(notes[0].msg.type, "Some.Note");
    poll_until(c, [&] { return script.wait_for(0s) == std::future_status::ready; });
    EXPECT_EQ(script.get(), "ok");
}

std::string frame_of(const std::string& xml) {
    return encode_frame(frame{frame_tag::message, xml, {}});
}

// A delivery the client cannot read is never lost silently: answered RECEIVE_ERROR, counted
// and reported (OA-MSG-20). Psyclone's barrier wakeup (priority="7.00") is read (OA-MSG-19).
TEST(ClientSocket, UnreadableDeliveriesAreCountedAndReported) {
    std::string barrier =
        test::read_file(test::vectors_dir() + "/legacy/psy2-cc003-barrier-wakeup.xml");
    std::string bad_trigger = barrier;
    const std::string legacy_priority = "priority=\"7.00\"";
    bad_trigger.replace(bad_trigger.find(legacy_priority), legacy_priority.size(),
                        "priority=\"high\"");
    fake_server server;
    std::uint16_t module_port = fake_server::free_port();
    auto script = std::async(std::launch::async, [&] {
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), true);
        primary.reply(primary.expect("BIND"), "BIND_ACCEPT", std::to_string(module_port));
        peer callback = server.accept();
        (void)callback.read_frame();
        primary.reply(primary.expect("Psyclone.Module.Connect.Mod"), "RECEIVE_ACCEPT");
        peer delivery = fake_server::connect_to(module_port);
        delivery.send_raw(frame_of(barrier));
        delivery.expect("RECEIVE_ACCEPT");
        delivery.send_raw(frame_of(bad_trigger));
        delivery.expect("RECEIVE_ERROR");
        delivery.send_raw(frame_of("<message><type>Direct</type><to>Mod</to"));
        delivery.expect("RECEIVE_ERROR");  // OA-ERR-3: the connection stays usable
        delivery.send_raw(frame_of(barrier));
        delivery.expect("RECEIVE_ACCEPT");
        return std::string("ok");
    });
    client_options o = options_for(server);
    o.listen = true;
    client c = client::connect(o);
    std::vector<std::string> reasons;
    std::vector<wakeup_event> wakeups;
    c.on_dropped_delivery([&](const std::string& why) { reasons.push_back(why); });
    c.on_wakeup([&](const wakeup_event& e) { wakeups.push_back(e); });
    poll_until(c, [&] { return script.wait_for(0s) == std::future_status::ready; });
    poll_until(c, [&] { return wakeups.size() >= 2; });
    EXPECT_EQ(script.get(), "ok");
    EXPECT_EQ(c.undecodable_deliveries(), 2u);
    ASSERT_EQ(reasons.size(), 2u);
    EXPECT_NE(reasons[0].find("priority"), std::string::npos) << reasons[0];
    EXPECT_NE(reasons[1].find("XML_MALFORMED"), std::string::npos) << reasons[1];
    ASSERT_EQ(wakeups.size(), 2u);
    ASSERT_TRUE(wakeups[0].wakeup.trigger.has_value());
    EXPECT_EQ(wakeups[0].wakeup.trigger->priority, std::optional<double>(6.999));
}

TEST(ClientSocket, FailureRepliesAreRequestFailed) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), true);
        primary.reply(primary.expect("Test.One"), "RECEIVE_ERROR", "STORE_FAILED: disk full",
                      "WB1");
        primary.reply(primary.expect("Test.Two"), "RECEIVE_ERROR", "something odd", "WB1");
        primary.reply(primary.expect("AIR.Retrieve"), "AIR.Retrieve.Failed",
                      "WHITEBOARD_UNKNOWN: NoSuchWB");
        message ok = primary.expect("AIR.Retrieves");
        message result = ok.reply("AIR.Retrieves.Success", "WB1");
        result.content_is_xml = true;
        result.language = "xml";
        message stored = make_message("Ret.A.1", "P", "WB1");
        stored.stored = "WB1";
        stored.wbid = 3;
        result.content =
            "<objectcollection><object>" + encode_message(stored) + "</object></objectcollection>";
        primary.send(result);
        return std::string("ok");
    });
    client_options o = options_for(server);
    o.bind = false;  // a plain client: no BIND, no callback
    client c = client::connect(o);
    try {
        (void)c.post("WB1", "Test.One");
        ADD_FAILURE();
    } catch (const request_failed& e) {
        EXPECT_EQ(e.code(), errc::request_failed);
        EXPECT_EQ(e.condition(), std::optional<errc>(errc::store_failed));  // OA-ERR-2
        EXPECT_EQ(e.reply().type, "RECEIVE_ERROR");
    }
    try {
        (void)c.post("WB1", "Test.Two");
        ADD_FAILURE();
    } catch (const request_failed& e) {
        EXPECT_FALSE(e.condition().has_value());  // OA-ERR-8
    }
    retrieve_spec spec;
    spec.whiteboard = "NoSuchWB";
    try {
        (void)c.retrieve(spec);
        ADD_FAILURE();
    } catch (const request_failed& e) {
        EXPECT_EQ(e.condition(), std::optional<errc>(errc::whiteboard_unknown));
    }
    std::vector<message> found = c.retrieve(std::vector<retrieve_spec>{spec, spec});
    ASSERT_EQ(found.size(), 1u);
    EXPECT_EQ(found[0].wbid, std::optional<std::uint64_t>(3));
    try {
        (void)c.post("WB1", "Bad..Type");
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::type_invalid);  // refused locally, nothing sent
    }
    EXPECT_EQ(script.get(), "ok");
}

TEST(ClientSocket, TimeoutClosesTheConnection) {
    fake_server server;
    std::promise<void> release;
    auto script = std::async(std::launch::async, [&server, &release] {
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), true);
        (void)primary.expect("Test.Slow");    // never answered
        bool closed = primary.wait_closed();  // OA-SESS-27: the client gives the connection up
        release.get_future().wait();
        return closed;
    });
    client_options o = options_for(server);
    o.bind = false;
    o.request_timeout = 300ms;
    client c = client::connect(o);
    try {
        (void)c.post("WB1", "Test.Slow");
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::request_timeout);
        EXPECT_EQ(e.blame(), blame::local);
    }
    EXPECT_FALSE(c.connected());
    try {
        (void)c.post("WB1", "Test.After");
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);  // reconnect is off
    }
    release.set_value();
    EXPECT_TRUE(script.get());
}

TEST(ClientSocket, ReconnectsAndRestoresTheRegistration) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        {
            peer primary = server.accept();
            peer callback = handshake_nolisten(server, primary, false);
            primary.reply(primary.expect("AIR.Subscribe"), "RECEIVE_ACCEPT", "", "AIRCentral");
        }  // both connections dropped: the server "restarts"
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), false);
        primary.reply(primary.expect("BIND_NOLISTEN"), "BIND_ACCEPT", "-1");
        peer callback = server.accept();
        (void)callback.read_frame();
        message again = primary.expect("AIR.Subscribe");  // the registration is sent again
        primary.reply(again, "RECEIVE_ACCEPT", "", "AIRCentral");
        primary.reply(primary.expect("Psyclone.Module.Reconnect.Mod"), "RECEIVE_ACCEPT");
        primary.reply(primary.expect("Test.After"), "RECEIVE_ACCEPT", "", "WB1");
        return again.content;
    });
    client_options o = options_for(server);
    o.reconnect = true;
    client c = client::connect(o);
    c.subscribe({trigger{"Test.*", "", 0, ""}});
    poll_until(c, [&c] { return c.generation() == 2; });  // the loss is noticed, then repaired
    message sent = c.post("WB1", "Test.After");
    EXPECT_EQ(sent.type, "Test.After");
    EXPECT_EQ(c.generation(), 2u);
    EXPECT_NE(script.get().find("type=\"Test.*\""), std::string::npos);
}

TEST(ClientSocket, GarbageFromTheServerFailsTheConnection) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), true);
        (void)primary.expect("Test.X");
        primary.send_raw(std::string("Garbage\0\x05\0\0\0hello", 17));  // OA-FRAME-6
        return primary.wait_closed();
    });
    client_options o = options_for(server);
    o.bind = false;
    client c = client::connect(o);
    try {
        (void)c.post("WB1", "Test.X");
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);
        EXPECT_NE(std::string(e.what()).find("FRAME_UNKNOWN_TAG"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(script.get());
}

TEST(ClientSocket, UnreachableServer) {
    std::uint16_t port = fake_server::free_port();
    client_options o;
    o.port = port;
    o.name = "Mod";
    o.request_timeout = 1000ms;
    try {
        (void)client::connect(o);
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);
    }
}

TEST(ClientSocket, MisuseIsLocal) {
    client_options o;
    o.listen = false;
    o.callback = false;
    o.name = "Mod";
    try {
        (void)client::connect(o);  // BIND_NOLISTEN without a callback connection
        ADD_FAILURE();
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::api_misuse);
    }
    o.callback = true;
    o.extensions = std::vector<std::string>{"auth"};
    EXPECT_THROW((void)client::connect(o), error);
}

TEST(ClientSocket, MovedFromClientRefusesWork) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        send_capabilities(primary, primary.expect("GET_CAPABILITIES"), false);
        return primary.wait_closed();
    });
    client_options o = options_for(server);
    o.bind = false;
    client a = client::connect(o);
    client b = std::move(a);
    EXPECT_TRUE(b.connected());
    EXPECT_FALSE(
        a.connected());  // NOLINT(bugprone-use-after-move): the moved-from state is defined
    EXPECT_THROW((void)a.poll(0ms), error);
    b.close();
    EXPECT_TRUE(script.get());
}

}  // namespace
}  // namespace openair
