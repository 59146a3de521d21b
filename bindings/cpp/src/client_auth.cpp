// Secure mode on the client's side (extension `auth`, spec 14.3): every connection the client
// opens for its name proves that name before it binds, acts or sends a Receive frame. Modelled
// on the reference client (reference/openair/client/auth.py).
#include <poll.h>

#include <cerrno>

#include "auth.hpp"
#include "client_impl.hpp"
#include "xml.hpp"

namespace openair {

namespace {

constexpr std::size_t read_size = 16 * 1024;

/// AUTH_FAILED naming what the server answered instead (never the secret nor the proof).
[[noreturn]] void refused(const message& reply, std::string_view request, const std::string& name) {
    std::string detail = std::string(request) + " for '" + name + "' answered " + reply.type;
    if (!reply.content.empty()) detail += ": " + std::string(detail::strip_ws(reply.content));
    throw error(errc::auth_failed, detail);
}

message challenge_for(const std::string& name) {
    return make_message(std::string(detail::auth_challenge), name, cns);
}

message response_for(const std::string& name, const std::string& secret, const message& nonce) {
    if (nonce.type != detail::auth_nonce) refused(nonce, detail::auth_challenge, name);
    message msg = make_message(std::string(detail::auth_response), name, cns);
    msg.content = detail::auth_proof(secret, detail::strip_ws(nonce.content), name);
    return msg;
}

void check_accepted(const message& reply, const std::string& name) {
    if (reply.type != detail::auth_accept) refused(reply, detail::auth_response, name);
}

}  // namespace

void client::impl::require_auth() const {
    // OA-AUTH-12: a client with a secret never binds at (nor sends a proof to) a server that
    // does not run in secure mode; it reports the refusal instead of falling back to legacy.
    if (!caps || !caps->has_extension(std::string(detail::auth_extension))) {
        throw error(errc::auth_required,
                    "the server does not run in secure mode (it does not advertise `auth`): "
                    "refusing to bind '" + opt.name + "' with a secret (OA-AUTH-12)");
    }
}

void client::impl::prove_primary() {
    require_auth();
    auto [sent, nonce] = request(challenge_for(opt.name));  // OA-AUTH-2
    auto [answer, reply] = request(response_for(opt.name, *opt.secret, nonce));  // OA-AUTH-3
    check_accepted(reply, opt.name);
}

void client::impl::prove_on(detail::connection& c) {
    require_auth();
    auto deadline = steady::now() + opt.request_timeout;
    message nonce = exchange_on(c, challenge_for(opt.name), deadline);
    check_accepted(exchange_on(c, response_for(opt.name, *opt.secret, nonce), deadline),
                   opt.name);
}

message client::impl::exchange_on(detail::connection& c, message msg,
                                  steady::time_point deadline) {
    c.out += c.sess.send_request(std::move(msg)).bytes;
    char buf[read_size];
    while (true) {
        flush(c);
        if (c.dead) throw error(errc::connection_closed, "while proving the name: " + c.reason);
        if (!(c.tls && c.tls->pending())) {  // poll(2) does not see bytes TLS already holds
            auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - steady::now());
            if (left.count() <= 0) {
                throw error(errc::request_timeout, "no answer to the proof of the name in time");
            }
            short events = static_cast<short>(POLLIN | (c.out.empty() ? 0 : POLLOUT));
            pollfd p{c.fd.get(), events, 0};
            int rc = ::poll(&p, 1, static_cast<int>(left.count()));
            if (rc < 0 && errno != EINTR) throw error(errc::connection_closed, "poll failed");
            if (rc <= 0 || (p.revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
        }
        detail::io_result r = detail::read_some(c, buf, sizeof buf);
        if (r.would_block) continue;
        if (r.closed) {
            throw error(errc::connection_closed,
                        "the server closed the connection while the name was proved" +
                            (r.reason.empty() ? std::string() : ": " + r.reason));
        }
        for (session_event& event : c.sess.receive_data(std::string_view(buf, r.bytes))) {
            if (auto* reply = std::get_if<reply_event>(&event)) return std::move(reply->msg);
            if (auto* failed = std::get_if<failed_event>(&event)) throw failed->failure;
            if (std::holds_alternative<closed_event>(event)) {
                throw error(errc::connection_closed, "the server closed the connection");
            }
        }
    }
}

}  // namespace openair
