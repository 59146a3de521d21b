// The client's I/O loop: one poll(2) over the primary, callback and accepted connections and
// the listening socket. Runs only on the caller's thread, inside client calls.
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <iostream>

#include "client_impl.hpp"
#include "openair/codec.hpp"
#include "stream_wire.hpp"
#include "test_faults.hpp"

namespace openair {

namespace {

constexpr std::size_t read_size = 64 * 1024;
constexpr int reads_per_round = 16;       // bytes from one busy peer never starve the others
constexpr std::size_t max_inbox = 10000;  // deliveries held for poll(); reading pauses beyond
constexpr std::chrono::milliseconds max_wait{1000};

}  // namespace

client::impl::impl(client_options o) : opt(std::move(o)) {
    if (opt.extensions) {
        for (const std::string& name : *opt.extensions) {
            if (client_extensions().count(name) == 0) {
                throw error(errc::api_misuse, "extension this client does not implement: " + name);
            }
            wanted.insert(name);
        }
    } else {
        wanted = client_extensions();
    }
    if (opt.bind && opt.name.empty()) throw error(errc::api_misuse, "a module needs a name");
    if (opt.bind && !opt.listen && !opt.callback) {
        throw error(errc::api_misuse, "BIND_NOLISTEN needs the callback connection (OA-DELIV-10)");
    }
    if (opt.secret && opt.name.empty()) {
        throw error(errc::api_misuse, "a secret proves a name: the client needs a name");
    }
    if (opt.tls.enabled) tls = std::make_unique<detail::tls_context>(
        detail::tls_settings{opt.tls.ca_file, opt.tls.verify_host});
    backoff = opt.reconnect_delay;
}

std::int64_t client::impl::now_ns() const {
    return opt.clock ? opt.clock() : system_clock_ns();
}

std::unique_ptr<detail::connection> client::impl::open(detail::conn_kind kind, role r) {
    auto c = std::make_unique<detail::connection>();
    c->id = next_conn_id++;
    c->kind = kind;
    c->fd = detail::connect_tcp(opt.host, opt.port, opt.request_timeout);
    if (tls) {  // OA-AUTH-10
        c->tls = std::make_unique<detail::tls_stream>(*tls, c->fd.get(), opt.host,
                                                      opt.request_timeout);
    }
    c->sess = session(r, opt.clock, 1, extensions, opt.name, opt.limits);
    // OA-AUTH-4, OA-AUTH-6: a callback, stream or push connection proves the name before its
    // first frame; the primary proves it after GET_CAPABILITIES (establish).
    if (opt.secret && kind != detail::conn_kind::primary) prove_on(*c);
    return c;
}

detail::connection* client::impl::find(int id) {
    if (primary && primary->id == id) return primary.get();
    if (callback && callback->id == id) return callback.get();
    for (auto& a : accepted) {
        if (a->id == id) return a.get();
    }
    for (auto& e : extra) {
        if (e->id == id) return e.get();
    }
    return nullptr;
}

void client::impl::flush(detail::connection& c) {
    while (!c.dead && !c.out.empty()) {
        detail::io_result r = detail::write_some(c, c.out);
        if (r.closed) {
            drop(c, "write failed: " + r.reason);
            return;
        }
        if (r.would_block) return;
        c.out.erase(0, r.bytes);
        c.last_traffic = steady::now();
    }
}

void client::impl::drop(detail::connection& c, const std::string& reason) {
    if (c.dead) return;
    c.dead = true;
    c.reason = reason;
    c.tls.reset();
    c.fd.reset();
    c.sess.close();
    c.out.clear();
    if (&c == primary.get()) primary_lost(reason);
    for (std::uint64_t t : c.tickets) {  // a stream connection's requests fail with it
        if (dropped.erase(t) != 0) {
            outcomes.erase(t);
        } else {
            outcomes[t] = error(errc::connection_closed, "stream connection lost: " + reason);
        }
    }
    c.tickets.clear();
    if (c.kind == detail::conn_kind::push) subscription_ended(c.id, reason);
}

void client::impl::primary_lost(const std::string& reason) {
    for (std::uint64_t t : tickets) {
        if (dropped.erase(t) != 0) {
            outcomes.erase(t);
            continue;
        }
        outcomes[t] = error(errc::connection_closed, "connection lost: " + reason);
    }
    tickets.clear();
    next_attempt = steady::now() + backoff;
}

void client::impl::answer_ready(detail::connection& c) {
    while (!c.dead && !c.answers.empty() && c.answers.front().ready) {
        detail::connection::answer_slot slot = std::move(c.answers.front());
        c.answers.pop_front();
        c.out += c.sess.answer(slot.seq, slot.type, slot.content);  // OA-SESS-2: in order
    }
    flush(c);
}

void client::impl::queue_delivery(detail::connection& c, request_event& req,
                                  std::int64_t received_ns) {
    const std::string& type = req.msg.type;
    if (type == "PING" || type == "KEEPALIVE") {  // OA-SESS-11, OA-KEEP-2: no callback
        if (req.needs_answer) c.answers.push_back({req.seq, true, "", ""});
        return;
    }
    delivery_path path =
        c.kind == detail::conn_kind::callback ? delivery_path::callback : delivery_path::listener;
    std::uint64_t seq = req.needs_answer ? req.seq : 0;  // OA-MSG-15: noreply is not answered
    if (type == "DATASAMPLE") {  // OA-STREAM-14: a sample the registration brings
        try {
            received_sample got = detail::received_sample_of(std::move(req.msg), received_ns);
            if (OPENAIR_FAULT(registration_samples_lost)) {  // test-only fault: acked, lost
                if (req.needs_answer) c.answers.push_back({req.seq, true, "", ""});
                return;
            }
            inbox.push_back({c.id, seq, std::move(got)});
        } catch (const error& e) {
            delivery_dropped("'DATASAMPLE': " + e.wire_text());
            if (req.needs_answer)
                c.answers.push_back({req.seq, true, "RECEIVE_ERROR", e.wire_text()});
            return;
        }
    } else if (type == wakeup_type) {
        try {
            wakeup w = parse_wakeup(req.msg);
            inbox.push_back(
                {c.id, seq, wakeup_event{std::move(w), std::move(req.msg), received_ns, path}});
        } catch (const error& e) {
            delivery_dropped("'" + type + "' " + req.msg.id + ": " + e.wire_text());
            // OA-SESS-11: a wakeup that cannot be read is answered RECEIVE_ERROR.
            if (req.needs_answer)
                c.answers.push_back({req.seq, true, "RECEIVE_ERROR", e.wire_text()});
            return;
        }
    } else {
        inbox.push_back({c.id, seq, message_event{std::move(req.msg), received_ns, path}});
    }
    if (req.needs_answer) c.answers.push_back({req.seq, false, "", ""});
}

void client::impl::handle_event(detail::connection& c, session_event& event,
                                std::int64_t received_ns) {
    if (auto* reply = std::get_if<reply_event>(&event)) {
        if (c.kind == detail::conn_kind::stream && !c.tickets.empty()) {
            std::uint64_t ticket = c.tickets.front();
            c.tickets.pop_front();
            if (dropped.erase(ticket) != 0) {
                outcomes.erase(ticket);
            } else {
                outcomes[ticket] = std::move(reply->msg);
            }
            return;
        }
        if (&c != primary.get() || tickets.empty()) return;  // a responder session pairs nothing
        std::uint64_t ticket = tickets.front();
        tickets.pop_front();
        if (dropped.erase(ticket) != 0) {
            outcomes.erase(ticket);
        } else {
            outcomes[ticket] = std::move(reply->msg);
        }
    } else if (auto* req = std::get_if<request_event>(&event)) {
        if (c.kind == detail::conn_kind::push) {
            queue_push(c, *req, received_ns);
        } else {
            queue_delivery(c, *req, received_ns);
        }
    } else if (auto* bad = std::get_if<invalid_event>(&event)) {
        if (OPENAIR_FAULT(crash_on_malformed)) std::_Exit(3);  // test-only fault
        delivery_dropped(bad->failure.wire_text());
        // OA-ERR-3: answered RECEIVE_ERROR, and the connection stays usable (test-only fault
        // accept_malformed: RECEIVE_ACCEPT instead).
        c.answers.push_back({bad->seq, true,
                             OPENAIR_FAULT(accept_malformed) ? "RECEIVE_ACCEPT" : "RECEIVE_ERROR",
                             bad->failure.wire_text()});
    } else if (std::holds_alternative<closed_event>(event)) {
        drop(c, "closed by the server");
    } else if (auto* failed = std::get_if<failed_event>(&event)) {
        // A delivery connection that breaks mid-frame loses that delivery (OA-MSG-20).
        if (c.kind == detail::conn_kind::callback || c.kind == detail::conn_kind::accepted) {
            delivery_dropped("delivery connection closed: " + failed->failure.wire_text());
        }
        drop(c, failed->failure.what());  // OA-FRAME-9: the stream cannot be trusted any more
    }
}

void client::impl::delivery_dropped(const std::string& reason) {
    ++undecodable;
    if (on_dropped) {
        on_dropped(reason);
    } else {
        std::clog << "openair: " << opt.name << ": delivery dropped: " << reason << '\n';
    }
}

void client::impl::handle_data(detail::connection& c, std::string_view data) {
    std::int64_t received_ns = now_ns();  // the first act on arrival
    c.last_rx = c.last_traffic = steady::now();
    std::vector<session_event> events =
        data.empty() ? c.sess.receive_eof() : c.sess.receive_data(data);
    for (session_event& event : events) {
        handle_event(c, event, received_ns);
        if (c.dead) break;
    }
    answer_ready(c);
}

void client::impl::reap() {
    accepted.erase(
        std::remove_if(accepted.begin(), accepted.end(), [](const auto& a) { return a->dead; }),
        accepted.end());
    extra.erase(std::remove_if(extra.begin(), extra.end(), [](const auto& e) { return e->dead; }),
                extra.end());
    if (callback && callback->dead) callback.reset();
}

void client::impl::pump(steady::time_point deadline) {
    std::vector<pollfd> fds;
    std::vector<detail::connection*> owners;  // nullptr: the listening socket
    bool inbox_full = inbox.size() >= max_inbox;
    auto add = [&](detail::connection* c) {
        if (c == nullptr || c->dead) return;
        short events = 0;
        if (!inbox_full || c->kind == detail::conn_kind::primary ||
            c->kind == detail::conn_kind::stream || c->kind == detail::conn_kind::push) {
            events |= POLLIN;  // replies, and pushes (bounded by their own buffers)
        }
        if (!c->out.empty()) events |= POLLOUT;
        fds.push_back({c->fd.get(), events, 0});
        owners.push_back(c);
    };
    add(primary.get());
    add(callback.get());
    for (auto& a : accepted) add(a.get());
    for (auto& e : extra) add(e.get());
    if (listener.valid() && !inbox_full) {
        fds.push_back({listener.get(), POLLIN, 0});
        owners.push_back(nullptr);
    }
    auto now = steady::now();
    bool buffered = false;  // TLS holds decrypted bytes that poll(2) cannot see
    for (detail::connection* c : owners) buffered = buffered || (c && c->tls && c->tls->pending());
    // Rounded up: a deadline less than 1 ms away would otherwise spin with poll(…, 0).
    auto wait = std::chrono::ceil<std::chrono::milliseconds>(deadline - now);
    wait = buffered ? std::chrono::milliseconds(0) : std::clamp(wait, {}, max_wait);
    int rc = ::poll(fds.data(), fds.size(), static_cast<int>(wait.count()));
    if (rc < 0 && errno != EINTR) throw error(errc::connection_closed, "poll failed");
    for (std::size_t i = 0; (rc > 0 || buffered) && i < fds.size(); ++i) {
        detail::connection* c = owners[i];
        if (fds[i].revents == 0 && !(c && c->tls && c->tls->pending())) continue;
        if (c == nullptr) {
            while (true) {  // OA-DELIV-2: any number of connections to the listening port
                detail::fd_handle fd = detail::accept_tcp(listener.get());
                if (!fd.valid()) break;
                auto a = std::make_unique<detail::connection>();
                a->id = next_conn_id++;
                a->kind = detail::conn_kind::accepted;
                a->fd = std::move(fd);
                a->sess = session(role::responder, opt.clock, 1, extensions, opt.name, opt.limits);
                accepted.push_back(std::move(a));
            }
            continue;
        }
        if (fds[i].revents & POLLOUT) flush(*c);
        if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) || (c->tls && c->tls->pending())) {
            char buf[read_size];
            for (int round = 0; round < reads_per_round && !c->dead; ++round) {
                detail::io_result r = detail::read_some(*c, buf, sizeof buf);
                if (r.would_block) break;
                if (r.closed) {
                    handle_data(*c, {});  // end of stream: FRAME_TRUNCATED inside a frame
                    drop(*c, r.reason.empty() ? "closed by the server" : r.reason);
                    break;
                }
                handle_data(*c, std::string_view(buf, r.bytes));
            }
        }
    }
    // OA-FRAME-12: a frame whose rest does not arrive in time is FRAME_TRUNCATED.
    now = steady::now();
    auto stalled = [&](detail::connection* c) {
        if (c != nullptr && !c->dead && c->sess.in_frame() &&
            now - c->last_rx > opt.frame_deadline) {
            drop(*c, "FRAME_TRUNCATED: no byte of the frame within the frame deadline");
        }
    };
    stalled(primary.get());
    stalled(callback.get());
    for (auto& a : accepted) stalled(a.get());
    for (auto& e : extra) stalled(e.get());
    reap();
}

}  // namespace openair
