// Secure mode on the client's side (extension `auth`, spec 14.3): the HMAC-SHA256 proof against
// the spec's worked example, the exchange on every connection against a scripted fake server,
// a refused proof, and the refusal to bind at a server that does not advertise `auth`.
#include <gtest/gtest.h>

#include <future>

#include "auth.hpp"
#include "fake_server.hpp"
#include "openair/client.hpp"
#include "openair/stream.hpp"

namespace openair {
namespace {

using test::fake_server;
using test::peer;
using namespace std::chrono_literals;

const std::string secret = "reader-secret-0123456789";

std::string nonce_of(int n) {  // 64 hex digits, different per connection
    std::string hex = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";
    hex[0] = static_cast<char>('0' + n);
    return hex;
}

void send_capabilities(peer& p, bool with_auth) {
    message ask = p.expect("GET_CAPABILITIES");
    message caps = ask.reply("CAPABILITIES", "CNS");
    caps.content = std::string("<capabilities protocol=\"OpenAIR/1.0\" server=\"fake/1\">") +
                   (with_auth ? "<extension name=\"auth\"/>" : "") +
                   "<extension name=\"noreply\"/></capabilities>";
    caps.content_is_xml = true;
    caps.language = "xml";
    p.send(caps);
}

/// Serve one challenge-response for `name` on `p`; accept when the proof is right.
void serve_proof(peer& p, const std::string& name, int n) {
    message challenge = p.expect("AUTH_CHALLENGE");
    if (challenge.sender != name || challenge.to != "CNS") {
        throw std::runtime_error("AUTH_CHALLENGE from " + challenge.sender + " to " + challenge.to);
    }
    p.reply(challenge, "AUTH_NONCE", nonce_of(n));
    message response = p.expect("AUTH_RESPONSE");
    if (response.content.find(secret) != std::string::npos) {
        throw std::runtime_error("the secret itself was sent (OA-AUTH-12)");
    }
    if (response.content != detail::auth_proof(secret, nonce_of(n), name)) {
        p.reply(response, "RECEIVE_ERROR", "AUTH_FAILED: proof does not verify");
        return;
    }
    p.reply(response, "AUTH_ACCEPT");
}

client_options secure_options(const fake_server& server) {
    client_options o;
    o.port = server.port();
    o.name = "Reader";
    o.listen = false;
    o.request_timeout = 5000ms;
    o.reconnect = false;
    o.secret = secret;
    return o;
}

TEST(Auth, ProofMatchesTheSpecExample) {
    // Spec 14.3's worked example (the Python and Java tests check the same numbers).
    EXPECT_EQ(detail::auth_proof(secret,
                                 "000102030405060708090a0b0c0d0e0f"
                                 "101112131415161718191a1b1c1d1e1f",
                                 "Reader"),
              "a07677b31933e5bbc655a3898e4781dccb13af8718b1a4d8a76f76ce308f4904");
    // Every input counts.
    EXPECT_NE(detail::auth_proof(secret, nonce_of(1), "Reader"),
              detail::auth_proof(secret, nonce_of(2), "Reader"));
    EXPECT_NE(detail::auth_proof(secret, nonce_of(1), "Reader"),
              detail::auth_proof(secret, nonce_of(1), "Writer"));
    EXPECT_NE(detail::auth_proof(secret, nonce_of(1), "Reader"),
              detail::auth_proof(secret + "x", nonce_of(1), "Reader"));
    EXPECT_EQ(detail::auth_proof(secret, nonce_of(1), "Reader").size(), 64u);
}

TEST(Auth, EveryConnectionProvesTheNameBeforeItActs) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        send_capabilities(primary, true);
        serve_proof(primary, "Reader", 1);  // OA-AUTH-5: before BIND_NOLISTEN
        message bind = primary.expect("BIND_NOLISTEN");
        primary.reply(bind, "BIND_ACCEPT", "-1");
        peer callback = server.accept();
        serve_proof(callback, "Reader", 2);  // OA-AUTH-6: before the Receive frame
        frame note = callback.read_frame();
        if (note.tag != frame_tag::receive || from_frame(note).type != "RECEIVE_NAME_NOTIFICATION")
            throw std::runtime_error("no Receive frame after the proof");
        message hello = primary.expect("Psyclone.Module.Connect.Reader");
        primary.reply(hello, "RECEIVE_ACCEPT", "", "AIRCentral");
        peer stream = server.accept();  // a stream handle's own connection
        serve_proof(stream, "Reader", 3);
        for (int i = 0; i < 2; ++i) {  // the one that opens the connection, then name()'s
            message ask = stream.expect("GET_NAME");
            stream.reply(ask, "NAME", "Cam", "Cam");
        }
        return std::string("ok");
    });
    client c = client::connect(secure_options(server));
    try {
        EXPECT_EQ(c.stream("Cam").name(), "Cam");
    } catch (const error& e) {
        ADD_FAILURE() << e.what();
    }
    EXPECT_EQ(script.get(), "ok");
}

TEST(Auth, RefusedProofFailsTheConnectWithoutBinding) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        send_capabilities(primary, true);
        message challenge = primary.expect("AUTH_CHALLENGE");
        primary.reply(challenge, "AUTH_NONCE", nonce_of(1));
        message response = primary.expect("AUTH_RESPONSE");
        primary.reply(response, "RECEIVE_ERROR", "AUTH_FAILED: proof does not verify");
        try {
            message more = primary.read();  // nothing more: no BIND after a refused proof
            return "sent " + more.type;
        } catch (const std::runtime_error&) {
            return std::string("ok");
        }
    });
    try {
        (void)client::connect(secure_options(server));
        ADD_FAILURE() << "connect succeeded with a refused proof";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::auth_failed);
        EXPECT_NE(std::string(e.what()).find("proof does not verify"), std::string::npos);
        EXPECT_EQ(std::string(e.what()).find(secret), std::string::npos);
    }
    EXPECT_EQ(script.get(), "ok");
}

TEST(Auth, SecretNeverGoesToAServerWithoutAuth) {
    for (bool legacy : {false, true}) {
        fake_server server;
        auto script = std::async(std::launch::async, [&server, legacy] {
            peer primary = server.accept();
            if (legacy) {
                message ask = primary.expect("GET_CAPABILITIES");
                primary.reply(ask, "UNKNOWN_COMMAND", "Offending cmd: GET_CAPABILITIES");
            } else {
                send_capabilities(primary, false);
            }
            try {
                message more = primary.read();  // OA-AUTH-12: no proof, no BIND
                return "sent " + more.type;
            } catch (const std::runtime_error&) {
                return std::string("ok");
            }
        });
        try {
            (void)client::connect(secure_options(server));
            ADD_FAILURE() << "bound at a server without auth";
        } catch (const error& e) {
            EXPECT_EQ(e.code(), errc::auth_required);
            EXPECT_NE(std::string(e.what()).find("OA-AUTH-12"), std::string::npos);
        }
        EXPECT_EQ(script.get(), "ok");
    }
}

TEST(Auth, SecretNeedsAName) {
    client_options o;
    o.bind = false;
    o.secret = secret;
    try {
        (void)client::connect(o);
        ADD_FAILURE() << "a secret without a name was accepted";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::api_misuse);
    }
}

TEST(Auth, TlsToAPlainServerFailsClearly) {
    fake_server server;
    auto script = std::async(std::launch::async, [&server] {
        peer primary = server.accept();
        primary.send_raw("not a TLS server\r\n\r\n");  // a ClientHello answered with junk
        (void)primary.wait_closed();  // a reset or an end of stream: either way, it is gone
        return true;
    });
    client_options o = secure_options(server);
    o.tls.enabled = true;
    try {
        (void)client::connect(o);
        ADD_FAILURE() << "TLS handshake with a plain server succeeded";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);
        EXPECT_NE(std::string(e.what()).find("TLS"), std::string::npos);
    }
    (void)script.get();  // the fake server saw the client go
}

TEST(Auth, UnreadableCaFileIsReported) {
    client_options o;
    o.name = "Reader";
    o.tls.enabled = true;
    o.tls.ca_file = "/nonexistent/ca.pem";
    try {
        (void)client::connect(o);
        ADD_FAILURE() << "a missing CA file was accepted";
    } catch (const error& e) {
        EXPECT_EQ(e.code(), errc::connection_closed);
        EXPECT_NE(std::string(e.what()).find("/nonexistent/ca.pem"), std::string::npos);
    }
}

}  // namespace
}  // namespace openair
