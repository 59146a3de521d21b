// The client: connect, negotiate, bind, register, post, retrieve, deliveries (spec 6-9, 15).
// Modelled on JavaOpenAIR's session set-up and the reference client (reference/openair/client).
#include "openair/client.hpp"

#include <algorithm>
#include <exception>

#include "client_impl.hpp"
#include "numbers.hpp"
#include "openair/types.hpp"
#include "test_faults.hpp"
#include "xml.hpp"

namespace openair {

namespace {

/// `reply` when its type is `type`, else REQUEST_FAILED carrying both messages.
const message& expect(const message& sent, const message& reply, std::string_view type) {
    if (reply.type != type) throw request_failed(sent, reply);
    return reply;
}

}  // namespace

// -- request_failed --------------------------------------------------------------------------

request_failed::request_failed(message request, message reply)
    : error(errc::request_failed, request.type + " answered " + reply.type +
                                      (reply.content.empty() ? "" : ": " + reply.content)),
      request_(std::move(request)),
      reply_(std::move(reply)) {}

std::optional<errc> request_failed::condition() const {
    std::string_view content = reply_.content;
    auto code = errc_from_name(detail::strip_ws(content.substr(0, content.find(':'))));
    if (!code || errc_is_local(*code)) return std::nullopt;  // OA-ERR-7, OA-ERR-8
    return code;
}

// -- requests on the primary connection ------------------------------------------------------

std::pair<message, std::uint64_t> client::impl::submit(message msg, steady::time_point deadline) {
    while (true) {
        if (!primary || primary->dead) {
            std::string why = primary ? primary->reason : std::string("not connected");
            throw error(errc::connection_closed, "the connection to the server is closed: " + why);
        }
        if (msg.noreply || primary->sess.can_send()) break;  // OA-SESS-17, OA-SESS-18
        if (steady::now() >= deadline) {
            throw error(errc::request_timeout, msg.type + ": no request slot in time");
        }
        pump(deadline);
    }
    outgoing o = primary->sess.send_request(std::move(msg));
    std::uint64_t ticket = 0;
    if (!o.sent.noreply) {
        ticket = next_ticket++;
        tickets.push_back(ticket);
        outcomes[ticket] = std::monostate{};
    }
    primary->out += o.bytes;
    flush(*primary);
    return {std::move(o.sent), ticket};
}

message client::impl::wait(std::uint64_t ticket, steady::time_point deadline) {
    while (true) {
        auto it = outcomes.find(ticket);
        if (it == outcomes.end()) throw error(errc::connection_closed, "the request was dropped");
        if (auto* reply = std::get_if<message>(&it->second)) {
            message out = std::move(*reply);
            outcomes.erase(it);
            return out;
        }
        if (auto* failure = std::get_if<error>(&it->second)) {
            error e = *failure;
            outcomes.erase(it);
            throw e;
        }
        if (steady::now() >= deadline) {
            // OA-SESS-27: a late reply could no longer be paired, so the connection goes.
            if (primary) drop(*primary, "no reply within the request timeout");
            outcomes.erase(ticket);
            throw error(errc::request_timeout,
                        "no reply within " + std::to_string(opt.request_timeout.count()) + " ms");
        }
        pump(deadline);
    }
}

std::pair<message, message> client::impl::request(message msg) {
    auto deadline = steady::now() + opt.request_timeout;
    auto [sent, ticket] = submit(std::move(msg), deadline);
    return {std::move(sent), wait(ticket, deadline)};
}

message client::impl::declare(message msg) const {
    if (legacy) return msg;  // OA-GEN-2: a legacy server never sees an extension's wire form
    std::string names;
    for (const std::string& name : extensions) names += (names.empty() ? "" : " ") + name;
    msg.set_extra("extensions", names);  // OA-SESS-19
    return msg;
}

// -- establishing the session -----------------------------------------------------------------

void client::impl::negotiate() {
    message ask = make_message("GET_CAPABILITIES", opt.name, cns);  // OA-SESS-23
    auto [sent, reply] = request(std::move(ask));
    caps.reset();
    if (reply.type == "CAPABILITIES") {
        try {
            caps = parse_capabilities(reply.content);
        } catch (const error&) {
            caps.reset();  // unreadable capabilities: treated as legacy
        }
    }
    legacy = !caps;  // OA-CAP-2: UNKNOWN_COMMAND (or anything else) means legacy
    extensions.clear();
    if (caps) {
        for (const std::string& name : wanted) {
            if (caps->has_extension(name)) extensions.insert(name);  // OA-GEN-2
        }
    }
    std::size_t window = 1;
    if (extensions.count("pipelining") != 0) {
        auto limit = caps->limit("max-in-flight").value_or(default_max_in_flight);
        window = static_cast<std::size_t>(std::clamp<std::uint64_t>(limit, 1, 1u << 20));
    }
    if (OPENAIR_FAULT(pipelining_to_legacy)) window = std::max<std::size_t>(window, 8);  // test
    primary->sess.set_extensions(extensions);
    primary->sess.set_window(window);
}

void client::impl::bind_and_receive() {
    message bind = declare(make_message(opt.listen ? "BIND" : "BIND_NOLISTEN", opt.name, cns));
    auto [sent, reply] = request(std::move(bind));
    expect(sent, reply, "BIND_ACCEPT");
    auto port = detail::parse_int64(reply.content, true);  // OA-SESS-3, OA-SESS-5
    if (!port || *port < -1 || *port > 65535) throw request_failed(sent, reply);
    bound_port = static_cast<int>(*port);
    if (opt.listen && bound_port > 0 && listening_port != bound_port) {
        listener.reset();
        listening_port.reset();
        // OA-DELIV-10: listen on the BIND_ACCEPT port, on the interface that reaches the server.
        listener = detail::listen_tcp(detail::local_host(primary->fd.get()),
                                      static_cast<std::uint16_t>(bound_port));
        listening_port = static_cast<std::uint16_t>(bound_port);
    }
    if (opt.callback && !OPENAIR_FAULT(no_callback)) {  // no_callback: test-only fault
        if (callback) drop(*callback, "replaced");
        auto c = open(detail::conn_kind::callback, role::requester);
        message note = declare(make_message("RECEIVE_NAME_NOTIFICATION", opt.name));
        outgoing o = c->sess.send_notification(std::move(note));  // OA-SESS-7
        c->out += o.bytes;
        flush(*c);
        callback = std::move(c);
    }
}

void client::impl::send_registration() {
    message msg = make_message("AIR.Subscribe", opt.name, aircentral);
    msg.language = "xml";
    msg.content = encode_registration(opt.name, reg->triggers, reg->retrieves,
                                      reg->allow_self_triggering, reg->streams);
    msg.content_is_xml = true;
    auto [sent, reply] = request(std::move(msg));
    expect(sent, reply, "RECEIVE_ACCEPT");  // OA-REG-7
}

void client::impl::announce(bool first) {
    std::string type =
        std::string("Psyclone.Module.") + (first ? "Connect." : "Reconnect.") + opt.name;
    if (!is_valid_type(type)) return;  // a module name that cannot form a type: nothing to say
    auto [sent, reply] = request(make_message(type, opt.name, aircentral));
    expect(sent, reply, "RECEIVE_ACCEPT");
}

void client::impl::establish(bool first) {
    primary = open(detail::conn_kind::primary, role::requester);
    try {
        negotiate();
        if (opt.secret) prove_primary();  // before BIND and anything that acts (OA-AUTH-5)
        if (opt.bind) {
            bind_and_receive();
            if (reg) send_registration();
            if (opt.announce) announce(first);
        }
    } catch (...) {
        if (primary) drop(*primary, "session set-up failed");
        throw;
    }
    ++generation;
    backoff = opt.reconnect_delay;
}

void client::impl::ensure_connected(steady::time_point deadline) {
    if (closed) throw error(errc::connection_closed, "the client is closed");
    if (primary && !primary->dead) return;
    std::string why = primary ? primary->reason : std::string("not connected");
    if (!opt.reconnect) throw error(errc::connection_closed, "the connection was lost: " + why);
    std::string last = why;
    while (steady::now() < deadline) {
        try {
            establish(false);
            return;
        } catch (const error& e) {
            last = e.what();
        }
        auto wake = std::min(deadline, steady::now() + backoff);
        backoff = std::min(backoff * 2, opt.reconnect_max_delay);
        do {
            pump(wake);  // deliveries on other connections are still served while waiting
        } while (steady::now() < wake);
    }
    throw error(errc::request_timeout, "not reconnected in time: " + last);
}

void client::impl::maintain() {
    auto now = steady::now();
    if (opt.reconnect && (!primary || primary->dead) && now >= next_attempt) {
        try {
            establish(false);
        } catch (const error&) {
            backoff = std::min(backoff * 2, opt.reconnect_max_delay);
            next_attempt = steady::now() + backoff;
        }
        return;
    }
    if (primary && !primary->dead && opt.keepalive.count() > 0 &&
        now - primary->last_traffic >= opt.keepalive && primary->sess.can_send()) {
        // OA-KEEP-1: empty from and to; OA-KEEP-3: an unanswered KEEPALIVE closes nothing.
        auto [sent, ticket] = submit(make_message("KEEPALIVE"), now);
        dropped.insert(ticket);
    }
}

std::size_t client::impl::dispatch() {
    std::size_t count = inbox.size();
    for (std::size_t done = 0; done < count; ++done) {
        detail::delivery d = std::move(inbox.front());
        inbox.pop_front();
        std::exception_ptr failure;
        in_callback = true;
        try {
            if (auto* w = std::get_if<wakeup_event>(&d.event)) {
                if (on_wakeup) on_wakeup(*w);
            } else if (auto* m = std::get_if<message_event>(&d.event)) {
                if (on_message) on_message(*m);
            } else if (auto* r = std::get_if<received_sample>(&d.event)) {
                if (on_sample) on_sample(*r);
            }
        } catch (...) {
            failure = std::current_exception();
        }
        in_callback = false;
        detail::connection* c = d.seq != 0 ? find(d.conn_id) : nullptr;
        if (c != nullptr && !c->dead) {
            for (auto& slot : c->answers) {
                if (slot.seq == d.seq) slot.ready = true;  // OA-DELIV-4: acknowledged now
            }
            answer_ready(*c);
        }
        if (failure) std::rethrow_exception(failure);
    }
    return count;
}

void client::impl::close_all() noexcept {
    closed = true;
    for (detail::connection* c : {primary.get(), callback.get()}) {
        if (c != nullptr && !c->dead) {
            (void)detail::write_some(*c, c->out);  // best effort for answers owed
            c->tls.reset();
            c->fd.reset();
            c->dead = true;
        }
    }
    for (auto& a : accepted) {
        if (!a->dead) (void)detail::write_some(*a, a->out);
    }
    for (auto& e : extra) {
        if (!e->dead) (void)detail::write_some(*e, e->out);
    }
    extra.clear();
    for (auto& sub : subscriptions) {
        if (!sub->ended) sub->ended = error(errc::connection_closed, "the client is closed");
    }
    for (auto& [target, st] : streams) st->conn_id = 0;
    accepted.clear();
    callback.reset();
    listener.reset();
    listening_port.reset();
    inbox.clear();
}

// -- the public face --------------------------------------------------------------------------

client::client(std::unique_ptr<impl> state) noexcept : impl_(std::move(state)) {}
client::client(client&& other) noexcept = default;
client& client::operator=(client&& other) noexcept = default;
client::~client() noexcept {
    if (impl_) impl_->close_all();
}

client::impl& client::self() const {
    if (!impl_) throw error(errc::api_misuse, "this client was moved from");
    return *impl_;
}

client client::connect(client_options options) {
    auto state = std::make_unique<impl>(std::move(options));
    state->establish(true);
    return client(std::move(state));
}

void client::on_wakeup(std::function<void(const wakeup_event&)> callback) {
    self().on_wakeup = std::move(callback);
}

void client::on_message(std::function<void(const message_event&)> callback) {
    self().on_message = std::move(callback);
}

void client::on_dropped_delivery(std::function<void(const std::string& reason)> callback) {
    self().on_dropped = std::move(callback);
}

void client::on_sample(std::function<void(const received_sample&)> callback) {
    self().on_sample = std::move(callback);
}

std::size_t client::poll(std::chrono::milliseconds timeout) {
    impl& s = self();
    if (s.in_callback) throw error(errc::api_misuse, "poll() called from inside a callback");
    if (s.closed) throw error(errc::connection_closed, "the client is closed");
    auto deadline = steady::now() + std::max(timeout, std::chrono::milliseconds(0));
    do {
        s.maintain();
        // Deliveries already queued go out at once: a legacy server sends nothing more until
        // they are acknowledged (OA-DELIV-5), so waiting for traffic would only add latency.
        s.pump(s.inbox.empty() ? deadline : steady::now());
    } while (s.inbox.empty() && !s.subscription_waiting() && steady::now() < deadline);
    return s.dispatch() + s.dispatch_subscriptions();
}

namespace {

message build_post(const std::string& from, const std::string& to, const std::string& type,
                   const std::string& content, const post_options& options) {
    validate_type(type);  // OA-TYPE-1: refused here rather than by the whiteboard
    message msg = make_message(type, from, to);
    for (const std::string& name : options.cc) msg.cc += (msg.cc.empty() ? "" : ";") + name;
    msg.priority = options.priority;
    msg.content = content;
    msg.content_is_xml = options.content_is_xml;
    msg.language = options.content_is_xml && options.language.empty() ? "xml" : options.language;
    msg.binary = options.binary;
    return msg;
}

}  // namespace

message client::post(const std::string& to, const std::string& type, const std::string& content,
                     const post_options& options) {
    impl& s = self();
    message msg = build_post(s.opt.name, to, type, content, options);
    s.ensure_connected(steady::now() + s.opt.request_timeout);
    auto [sent, reply] = s.request(std::move(msg));
    expect(sent, reply, "RECEIVE_ACCEPT");  // OA-WB-3
    return sent;
}

message client::post_noreply(const std::string& to, const std::string& type,
                             const std::string& content, const post_options& options) {
    impl& s = self();
    message msg = build_post(s.opt.name, to, type, content, options);
    auto deadline = steady::now() + s.opt.request_timeout;
    s.ensure_connected(deadline);
    msg.noreply = s.extensions.count("noreply") != 0;  // OA-GEN-2, OA-MSG-15
    if (OPENAIR_FAULT(noreply_to_legacy) && !msg.noreply) {  // test-only fault
        std::set<std::string> claimed = s.primary->sess.extensions();
        claimed.insert("noreply");
        s.primary->sess.set_extensions(std::move(claimed));
        msg.noreply = true;
    }
    auto [sent, ticket] = s.submit(std::move(msg), deadline);
    if (ticket != 0) s.dropped.insert(ticket);  // a legacy server still replies: dropped
    return sent;
}

std::vector<message> client::post_many(std::vector<message> messages) {
    impl& s = self();
    auto deadline = steady::now() + s.opt.request_timeout;
    s.ensure_connected(deadline);
    std::vector<std::pair<message, std::uint64_t>> pending;
    for (message& msg : messages) {
        if (msg.sender.empty()) msg.sender = s.opt.name;
        if (msg.id.empty()) msg.id = new_id();
        msg.noreply = false;
        pending.push_back(s.submit(std::move(msg), deadline));  // pipelined within the window
    }
    std::vector<message> sent_all;
    std::exception_ptr failure;
    for (auto& [sent, ticket] : pending) {
        try {
            expect(sent, s.wait(ticket, deadline), "RECEIVE_ACCEPT");
        } catch (const error&) {
            if (!failure) failure = std::current_exception();
        }
        sent_all.push_back(std::move(sent));
    }
    if (failure) std::rethrow_exception(failure);
    return sent_all;
}

void client::subscribe(std::vector<trigger> triggers, std::vector<retrieve_spec> retrieves,
                       bool allow_self_triggering, std::vector<std::string> streams) {
    impl& s = self();
    (void)encode_registration(s.opt.name, triggers, retrieves, allow_self_triggering,
                              streams);  // validate first
    s.ensure_connected(steady::now() + s.opt.request_timeout);
    std::optional<impl::registration> previous = std::move(s.reg);
    s.reg = impl::registration{std::move(triggers), std::move(retrieves), allow_self_triggering,
                               std::move(streams)};
    try {
        s.send_registration();
    } catch (...) {
        s.reg = std::move(previous);  // OA-REG-8: the previous registration stays in force
        throw;
    }
}

std::vector<message> client::retrieve(const std::vector<retrieve_spec>& specs,
                                      const std::string& to) {
    impl& s = self();
    if (specs.empty()) throw error(errc::api_misuse, "retrieve needs at least one spec");
    bool one = specs.size() == 1;
    message msg = make_message(one ? "AIR.Retrieve" : "AIR.Retrieves", s.opt.name, to);  // OA-RET-1
    msg.language = "xml";
    msg.content = one ? encode_retrieve(specs.front()) : encode_retrieves(specs);
    msg.content_is_xml = true;
    s.ensure_connected(steady::now() + s.opt.request_timeout);
    auto [sent, reply] = s.request(std::move(msg));
    expect(sent, reply, sent.type + ".Success");  // OA-RET-7
    try {
        return parse_message_collection(reply.content, std::move(reply.binary));  // OA-RET-19
    } catch (const error&) {
        throw request_failed(sent, reply);
    }
}

std::vector<message> client::retrieve(const retrieve_spec& spec, const std::string& to) {
    return retrieve(std::vector<retrieve_spec>{spec}, to);
}

message client::request(message msg) {
    impl& s = self();
    if (msg.id.empty()) msg.id = new_id();
    if (msg.sender.empty()) msg.sender = s.opt.name;
    msg.noreply = false;
    s.ensure_connected(steady::now() + s.opt.request_timeout);
    return s.request(std::move(msg)).second;
}

void client::reconnect() {
    impl& s = self();
    if (s.closed) throw error(errc::connection_closed, "the client is closed");
    if (s.primary && !s.primary->dead) s.drop(*s.primary, "reconnect requested");
    s.establish(false);
}

void client::close() noexcept {
    if (impl_) impl_->close_all();
}

bool client::connected() const noexcept {
    return impl_ && !impl_->closed && impl_->primary && !impl_->primary->dead;
}
bool client::legacy() const noexcept {
    return impl_ && impl_->legacy;
}
const std::optional<capabilities>& client::server_capabilities() const noexcept {
    static const std::optional<capabilities> none;
    return impl_ ? impl_->caps : none;
}
const std::set<std::string>& client::extensions() const noexcept {
    static const std::set<std::string> none;
    return impl_ ? impl_->extensions : none;
}
int client::bound_port() const noexcept {
    return impl_ ? impl_->bound_port : -1;
}
std::optional<std::uint16_t> client::listen_port() const noexcept {
    return impl_ ? impl_->listening_port : std::nullopt;
}
unsigned client::generation() const noexcept {
    return impl_ ? impl_->generation : 0;
}
std::uint64_t client::undecodable_deliveries() const noexcept {
    return impl_ ? impl_->undecodable : 0;
}
const std::string& client::name() const noexcept {
    static const std::string none;
    return impl_ ? impl_->opt.name : none;
}

}  // namespace openair
