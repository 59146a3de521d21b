// The client's stream side (spec section 11): stream handles on connections of their own, push
// subscriptions, alarms. Modelled on reference/openair/client/streams.py and stream_push.py,
// without threads: every wait pumps all of the client's connections (client_io.cpp).
#include <algorithm>
#include <atomic>

#include "client_impl.hpp"
#include "openair/stream.hpp"
#include "stream_wire.hpp"
#include "test_faults.hpp"
#include "xml.hpp"

namespace openair {

namespace {

constexpr const char* notification = "RECEIVE_NAME_NOTIFICATION";
constexpr std::chrono::milliseconds confirm_first{1};  // doubled up to confirm_max
constexpr std::chrono::milliseconds confirm_max{50};
std::atomic<unsigned> companions{0};

std::chrono::milliseconds left_until(steady::time_point deadline) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - steady::now());
    return std::max(std::chrono::milliseconds(0), left);
}

}  // namespace

// -- connections ------------------------------------------------------------------------------

detail::connection& client::impl::stream_conn(detail::stream_state& st) {
    if (closed) throw error(errc::connection_closed, "the client is closed");
    if (detail::connection* c = st.conn_id != 0 ? find(st.conn_id) : nullptr; c && !c->dead) {
        return *c;
    }
    auto deadline = steady::now() + opt.request_timeout;
    ensure_connected(deadline);  // the window and extensions come from the session
    auto c = open(detail::conn_kind::stream, role::requester);
    c->sess.set_extensions(extensions);
    c->sess.set_window(primary->sess.window());
    detail::connection& conn = *c;
    extra.push_back(std::move(c));
    // Any media command makes the stream this connection's current stream (OA-STREAM-11).
    message ask = detail::media_request(st.target, opt.name, "GET_NAME");
    message sent = ask;
    std::uint64_t ticket = submit_on(conn, std::move(ask), nullptr, deadline);
    message reply = wait_on(conn.id, ticket, deadline);
    st.name = std::string(detail::strip_ws(detail::expect_reply(sent, reply, "NAME").content));
    st.conn_id = conn.id;
    return conn;
}

std::uint64_t client::impl::submit_on(detail::connection& c, message msg,
                                      const std::vector<chunk_parts>* chunks,
                                      steady::time_point deadline) {
    int id = c.id;
    while (true) {
        detail::connection* now = find(id);
        if (now == nullptr || now->dead) {
            throw error(errc::connection_closed, "the stream connection is closed");
        }
        if (msg.noreply || now->sess.can_send()) break;  // OA-SESS-17, OA-SESS-18
        if (steady::now() >= deadline) {
            throw error(errc::request_timeout, msg.type + ": no request slot in time");
        }
        pump(deadline);
    }
    outgoing o = chunks ? c.sess.send_request_parts(std::move(msg), *chunks)
                        : c.sess.send_request(std::move(msg));
    std::uint64_t ticket = 0;
    if (!o.sent.noreply) {
        ticket = next_ticket++;
        c.tickets.push_back(ticket);
        outcomes[ticket] = std::monostate{};
    }
    if (c.out.empty()) {
        c.out = std::move(o.bytes);  // no second copy of a sample's payload
    } else {
        c.out += o.bytes;
    }
    flush(c);
    return ticket;
}

std::uint64_t client::impl::submit_binary(detail::connection& c, const chunk_parts& chunk,
                                          steady::time_point deadline) {
    int id = c.id;
    while (true) {
        detail::connection* now = find(id);
        if (now == nullptr || now->dead) {
            throw error(errc::connection_closed, "the stream connection is closed");
        }
        if (now->sess.can_send()) break;
        if (steady::now() >= deadline) {
            throw error(errc::request_timeout, "no request slot in time");
        }
        pump(deadline);
    }
    std::string bytes = c.sess.send_binary(chunk);
    std::uint64_t ticket = next_ticket++;
    c.tickets.push_back(ticket);
    outcomes[ticket] = std::monostate{};
    if (c.out.empty()) {
        c.out = std::move(bytes);
    } else {
        c.out += bytes;
    }
    flush(c);
    return ticket;
}

message client::impl::wait_on(int conn_id, std::uint64_t ticket, steady::time_point deadline) {
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
            if (detail::connection* c = find(conn_id)) drop(*c, "no reply in time");
            outcomes.erase(ticket);
            throw error(errc::request_timeout, "no reply from the stream in time");
        }
        pump(deadline);
    }
}

std::pair<message, message> client::impl::media(detail::stream_state& st, message msg,
                                                std::chrono::milliseconds extra_wait) {
    detail::connection& c = stream_conn(st);
    auto deadline = steady::now() + opt.request_timeout + extra_wait;
    message sent = msg;
    std::uint64_t ticket = submit_on(c, std::move(msg), nullptr, deadline);
    return {std::move(sent), wait_on(c.id, ticket, deadline)};
}

// -- push subscriptions -----------------------------------------------------------------------

detail::subscription_state* client::impl::subscription_of(int conn_id) {
    for (auto& sub : subscriptions) {
        if (sub->conn_id == conn_id) return sub.get();
    }
    return nullptr;
}

void client::impl::queue_push(detail::connection& c, request_event& req,
                              std::int64_t received_ns) {
    detail::subscription_state* sub = subscription_of(c.id);
    const message& msg = req.msg;
    if (msg.type == "DATASAMPLE" && sub != nullptr) {
        try {
            received_sample got = detail::received_sample_of(std::move(req.msg), received_ns);
            ++sub->received;
            sub->dropped += got.dropped;
            sub->queue.push_back(std::move(got));
        } catch (const error& e) {  // OA-ERR-3: refused, the connection stays usable
            if (req.needs_answer) {
                c.answers.push_back({req.seq, true, "RECEIVE_ERROR", e.wire_text()});
            }
            return;
        }
        if (!req.needs_answer) return;
        // Acknowledged once in the local buffer; a full buffer holds it back (OA-STREAM-8).
        if (OPENAIR_FAULT(push_no_ack)) {  // test-only fault: an answer that is never sent
            c.answers.push_back({req.seq, false, "", ""});
            return;
        }
        bool room = sub->queue.size() <= sub->buffer;
        c.answers.push_back({req.seq, room, "", ""});
        if (!room) sub->held.push_back(req.seq);
        return;
    }
    if (sub != nullptr && (!msg.isresponse.empty() || msg.type == "RECEIVE_ERROR")) {
        // The notification was refused (STREAM_UNKNOWN): nothing answers it.
        std::string_view content = msg.content;
        auto code = errc_from_name(detail::strip_ws(content.substr(0, content.find(':'))));
        sub->ended = error(code.value_or(errc::request_failed), msg.content);
        drop(c, "subscription refused: " + msg.content);
        return;
    }
    if (req.needs_answer) c.answers.push_back({req.seq, true, "", ""});  // PING, KEEPALIVE, …
}

void client::impl::release_held(detail::subscription_state& sub) {
    detail::connection* c = find(sub.conn_id);
    while (!sub.held.empty() && sub.queue.size() < sub.buffer + 1) {
        std::uint64_t seq = sub.held.front();
        sub.held.pop_front();
        if (c == nullptr || c->dead) continue;
        for (auto& slot : c->answers) {
            if (slot.seq == seq) slot.ready = true;
        }
    }
    if (c != nullptr && !c->dead) answer_ready(*c);
}

void client::impl::subscription_ended(int conn_id, const std::string& reason) {
    if (detail::subscription_state* sub = subscription_of(conn_id)) {
        if (!sub->ended) {
            sub->ended = error(errc::connection_closed, "push connection lost: " + reason);
        }
    }
}

bool client::impl::subscription_waiting() const {
    return std::any_of(subscriptions.begin(), subscriptions.end(),
                       [](const auto& s) { return s->callback && !s->queue.empty(); });
}

std::size_t client::impl::dispatch_subscriptions() {
    std::size_t count = 0;
    for (auto& sub : subscriptions) {
        while (sub->callback && !sub->queue.empty()) {
            received_sample got = std::move(sub->queue.front());
            sub->queue.pop_front();
            release_held(*sub);
            ++count;
            in_callback = true;
            try {
                sub->callback(got);
            } catch (...) {
                in_callback = false;
                throw;
            }
            in_callback = false;
        }
    }
    return count;
}

// -- client: the public face of streams ---------------------------------------------------------

openair::stream& client::stream(const std::string& target) {
    impl& s = self();
    if (target.empty()) throw error(errc::api_misuse, "a stream handle needs a name or type");
    auto& slot = s.streams[target];
    if (!slot) {
        slot = std::make_unique<detail::stream_state>();
        slot->owner = &s;
        slot->target = target;
        slot->handle.reset(new openair::stream(slot.get()));
    }
    return *slot->handle;
}

stream_subscription& client::subscribe_stream(const std::string& target, std::size_t buffer) {
    impl& s = self();
    if (buffer < 1) throw error(errc::api_misuse, "a subscription buffer holds at least 1 sample");
    openair::stream& handle = stream(target);
    std::uint64_t before = handle.info().subscribers;
    auto sub = std::make_unique<detail::subscription_state>();
    sub->owner = &s;
    sub->target = target;
    sub->buffer = buffer;
    // OA-DELIV-5: without pipelining one sample is in flight, so `buffer` bounds what waits here.
    std::set<std::string> accepted = s.extensions;
    accepted.erase("pipelining");
    auto c = s.open(detail::conn_kind::push, role::requester);
    c->sess.set_extensions(accepted);
    message note = make_message(notification, s.opt.name, target);  // OA-STREAM-8
    if (!s.legacy) {  // OA-SESS-19: declare what this connection accepts
        std::string names;
        for (const std::string& name : accepted) names += (names.empty() ? "" : " ") + name;
        note.set_extra("extensions", names);
    }
    c->out += c->sess.send_notification(std::move(note)).bytes;
    sub->conn_id = c->id;
    s.flush(*c);
    s.extra.push_back(std::move(c));
    detail::subscription_state& state = *sub;
    state.handle.reset(new stream_subscription(sub.get()));
    s.subscriptions.push_back(std::move(sub));
    // Nothing answers a notification that worked: confirm it by the subscriber count.
    auto deadline = steady::now() + s.opt.request_timeout;
    auto delay = confirm_first;
    while (handle.info().subscribers <= before) {
        if (state.ended) {
            error e = *state.ended;
            state.handle->close();
            throw e;
        }
        if (steady::now() >= deadline) {
            state.handle->close();
            throw error(errc::request_timeout, "subscription to '" + target + "' not confirmed");
        }
        auto wake = steady::now() + delay;
        while (steady::now() < wake && !state.ended) s.pump(wake);
        delay = std::min(delay * 2, confirm_max);
    }
    return *state.handle;
}

std::vector<stream_info> client::list_streams() {
    message msg = make_message("GET_STREAMS", self().opt.name, cns);
    message sent = msg;
    message reply = request(std::move(msg));
    detail::expect_reply(sent, reply, "STREAMS");
    return detail::stream_list_of(reply.content);
}

// -- alarms -------------------------------------------------------------------------------------

struct alarm_subscription::state {
    std::unique_ptr<client> companion;
    std::deque<stream_alarm> alarms;
};

alarm_subscription::alarm_subscription(std::unique_ptr<state> s) noexcept : state_(std::move(s)) {}
alarm_subscription::alarm_subscription(alarm_subscription&&) noexcept = default;
alarm_subscription& alarm_subscription::operator=(alarm_subscription&&) noexcept = default;
alarm_subscription::~alarm_subscription() noexcept { close(); }

void alarm_subscription::close() noexcept {
    if (state_ && state_->companion) state_->companion->close();
}

std::optional<stream_alarm> alarm_subscription::next(std::chrono::milliseconds timeout) {
    if (!state_ || !state_->companion) throw error(errc::api_misuse, "a moved-from subscription");
    auto deadline = steady::now() + timeout;
    while (state_->alarms.empty()) {
        auto left = left_until(deadline);
        if (left.count() == 0) return std::nullopt;
        state_->companion->poll(left);
    }
    stream_alarm alarm = std::move(state_->alarms.front());
    state_->alarms.pop_front();
    return alarm;
}

alarm_subscription client::alarms(const std::string& pattern, const std::string& whiteboard) {
    impl& s = self();
    client_options o = s.opt;
    o.name = s.opt.name + "-alarms-" + std::to_string(++companions);
    o.listen = false;
    o.callback = true;
    o.announce = false;
    o.keepalive = std::chrono::milliseconds(0);
    auto st = std::make_unique<alarm_subscription::state>();
    st->companion = std::make_unique<client>(client::connect(o));
    auto* queue = &st->alarms;
    st->companion->on_wakeup([queue](const wakeup_event& e) {
        if (e.wakeup.trigger && detail::is_alarm(*e.wakeup.trigger)) {  // not a phase update
            queue->push_back(detail::alarm_of(*e.wakeup.trigger));
        }
    });
    st->companion->subscribe({trigger{pattern, whiteboard, 0, ""}});
    return alarm_subscription(std::move(st));
}

// -- stream ---------------------------------------------------------------------------------------

namespace {

// Helpers are templates on the client's state so that they need not name the private
// client::impl (stream, a friend of client, passes it in).

template <typename Impl>
void require_typed(Impl& s, const char* command) {
    // OA-GEN-2: a typed-streams command only towards a server that advertises it.
    if (s.extensions.count("typed-streams") == 0 &&
        !(s.caps && s.caps->has_extension("typed-streams"))) {
        throw error(errc::api_misuse,
                    std::string(command) + " needs a server that advertises typed-streams");
    }
}

}  // namespace

const std::string& stream::target() const noexcept { return state_->target; }

std::string stream::name() {
    auto& s = *state_->owner;
    message ask = detail::media_request(state_->target, s.opt.name, "GET_NAME");
    auto [sent, reply] = s.media(*state_, std::move(ask));
    return std::string(detail::strip_ws(detail::expect_reply(sent, reply, "NAME").content));
}

std::uint64_t stream::add(bytes_view payload, const sample_options& options) {
    auto& s = *state_->owner;
    sample_params params = detail::params_for(options);
    std::vector<chunk_parts> chunks{make_chunk_parts(payload, params)};
    detail::connection& c = s.stream_conn(*state_);
    auto deadline = steady::now() + s.opt.request_timeout;
    message msg = detail::add_request(state_->target, s.opt.name, 1);
    message sent = msg;
    std::uint64_t ticket = s.submit_on(c, std::move(msg), &chunks, deadline);
    message reply = s.wait_on(c.id, ticket, deadline);
    return detail::integer_of(detail::expect_reply(sent, reply, "DATA_ACCEPTED"), "sample id");
}

void stream::add_noreply(bytes_view payload, const sample_options& options) {
    auto& s = *state_->owner;
    std::vector<chunk_parts> chunks{make_chunk_parts(payload, detail::params_for(options))};
    detail::connection& c = s.stream_conn(*state_);
    message msg = detail::add_request(state_->target, s.opt.name, 1);
    msg.noreply = s.extensions.count("noreply") != 0;  // OA-GEN-2, OA-MSG-15
    std::uint64_t ticket =
        s.submit_on(c, std::move(msg), &chunks, steady::now() + s.opt.request_timeout);
    if (ticket != 0) s.dropped.insert(ticket);  // no noreply: the reply is read and dropped
}

std::uint64_t stream::add_binary(bytes_view payload, const sample_options& options) {
    return add_pipelined({payload}, {options}, true).front();
}

namespace {

const sample_options& options_at(const std::vector<sample_options>& options, std::size_t i,
                                  std::size_t count) {
    static const sample_options none;
    if (options.empty()) return none;
    if (options.size() == 1) return options.front();
    if (options.size() != count) {
        throw error(errc::api_misuse, "give no options, one for all, or one per payload");
    }
    return options[i];
}

}  // namespace

std::vector<std::uint64_t> stream::add_many(const std::vector<bytes_view>& payloads,
                                            const std::vector<sample_options>& options) {
    auto& s = *state_->owner;
    std::vector<chunk_parts> chunks;
    for (std::size_t i = 0; i < payloads.size(); ++i) {
        const sample_options& o = options_at(options, i, payloads.size());
        sample_params params = detail::params_for(o);
        chunks.push_back(make_chunk_parts(payloads[i], params));
    }
    if (chunks.size() == 1) return {add(payloads.front(), options_at(options, 0, 1))};
    detail::connection& c = s.stream_conn(*state_);
    auto deadline = steady::now() + s.opt.request_timeout;
    message msg = detail::add_request(state_->target, s.opt.name, chunks.size());
    message sent = msg;
    std::uint64_t ticket = s.submit_on(c, std::move(msg), &chunks, deadline);
    message reply = s.wait_on(c.id, ticket, deadline);
    return detail::ids_of(detail::expect_reply(sent, reply, "DATA_ACCEPTED").content);
}

std::vector<std::uint64_t> stream::add_pipelined(const std::vector<bytes_view>& payloads,
                                                 const std::vector<sample_options>& options,
                                                 bool binary) {
    auto& s = *state_->owner;
    detail::connection& c = s.stream_conn(*state_);
    int conn_id = c.id;
    auto deadline = steady::now() + s.opt.request_timeout;
    std::vector<std::pair<message, std::uint64_t>> pending;
    for (std::size_t i = 0; i < payloads.size(); ++i) {
        detail::connection* now = s.find(conn_id);
        if (now == nullptr) throw error(errc::connection_closed, "the stream connection is closed");
        chunk_parts parts = make_chunk_parts(payloads[i], detail::params_for(options_at(
                                                              options, i, payloads.size())));
        if (binary) {  // OA-STREAM-11: the connection's current stream is this one (GET_NAME)
            message sent = make_message("BinaryM", s.opt.name, state_->target);
            pending.emplace_back(std::move(sent), s.submit_binary(*now, parts, deadline));
        } else {
            std::vector<chunk_parts> chunks{std::move(parts)};
            message msg = detail::add_request(state_->target, s.opt.name, 1);
            message sent = msg;
            std::uint64_t ticket = s.submit_on(*now, std::move(msg), &chunks, deadline);
            pending.emplace_back(std::move(sent), ticket);
        }
    }
    std::vector<std::uint64_t> ids;
    for (auto& [sent, ticket] : pending) {
        message reply = s.wait_on(conn_id, ticket, deadline);
        const message& accepted = detail::expect_reply(sent, reply, "DATA_ACCEPTED");
        ids.push_back(detail::integer_of(accepted, "sample id"));
    }
    return ids;
}

namespace {

template <typename Impl>
data_sample one_sample(Impl& s, detail::stream_state& st, const std::string& type,
                       std::string content = "", bool xml = false) {
    auto [sent, reply] = s.media(st, detail::media_request(st.target, s.opt.name, type,
                                                           std::move(content), xml));
    detail::expect_reply(sent, reply, "DATASAMPLE");
    return detail::sample_of(std::move(reply));
}

template <typename Impl>
message asked(Impl& s, detail::stream_state& st, const std::string& type,
              const char* expected, std::string content = "", bool xml = false) {
    auto [sent, reply] = s.media(st, detail::media_request(st.target, s.opt.name, type,
                                                           std::move(content), xml));
    detail::expect_reply(sent, reply, expected);
    return std::move(reply);
}

}  // namespace

data_sample stream::get(std::uint64_t id) {
    return one_sample(*state_->owner, *state_, "GET_SAMPLE_BY_ID", std::to_string(id));
}

data_sample stream::at(std::int64_t ms) {
    return one_sample(*state_->owner, *state_, "GET_SAMPLE_BY_TIME", detail::time_content(ms),
                      true);
}

std::vector<data_sample> stream::between(std::int64_t from_ms, std::int64_t until_ms) {
    message reply = asked(*state_->owner, *state_, "GET_SAMPLES_BY_TIME", "DATASAMPLES",
                          detail::range_content(from_ms, until_ms), true);
    return detail::samples_of(std::move(reply));
}

data_sample stream::newest() {
    return one_sample(*state_->owner, *state_, "GET_NEWEST_DATASAMPLE");
}
data_sample stream::oldest() {
    return one_sample(*state_->owner, *state_, "GET_OLDEST_DATASAMPLE");
}

std::int64_t stream::newest_timestamp() {
    return detail::timestamp_of(
        asked(*state_->owner, *state_, "GET_NEWEST_TIMESTAMP", "TIMESTAMP"));
}

std::int64_t stream::oldest_timestamp() {
    return detail::timestamp_of(
        asked(*state_->owner, *state_, "GET_OLDEST_TIMESTAMP", "TIMESTAMP"));
}

std::uint64_t stream::count() {
    return detail::integer_of(asked(*state_->owner, *state_, "GET_COUNT", "COUNT"), "count");
}

std::uint64_t stream::size() {
    return detail::integer_of(asked(*state_->owner, *state_, "GET_SIZE", "SIZE"), "size");
}

stream_info stream::info() {
    return detail::stream_info_of(asked(*state_->owner, *state_, "GET_INFO", "INFO").content);
}

std::vector<data_sample> stream::search(const sample_search& query) {
    require_typed(*state_->owner, "SEARCH_SAMPLES");
    message reply = asked(*state_->owner, *state_, "SEARCH_SAMPLES", "DATASAMPLES",
                          detail::search_content(query), true);
    return detail::samples_of(std::move(reply));
}

namespace {

template <typename Impl>
std::optional<data_sample> waited(Impl& s, detail::stream_state& st, std::string type,
                                  std::string content, bool xml,
                                  std::chrono::milliseconds timeout) {
    auto [sent, reply] =
        s.media(st, detail::media_request(st.target, s.opt.name, type, std::move(content), xml),
                timeout);
    if (reply.type == "DATASAMPLE") return detail::sample_of(std::move(reply));
    try {
        detail::raise_for(sent, reply);
    } catch (const error& e) {
        // OA-STREAM-7: timed out (test-only fault wait_timeout_error: reported as an error).
        if (e.code() == errc::sample_unknown && !OPENAIR_FAULT(wait_timeout_error)) {
            return std::nullopt;
        }
        throw;
    }
}

}  // namespace

std::optional<data_sample> stream::wait_after_id(std::uint64_t id,
                                                 std::chrono::milliseconds timeout, bool last) {
    return waited(*state_->owner, *state_, detail::wait_type(true, last, timeout.count()),
                  std::to_string(id), false, timeout);
}

std::optional<data_sample> stream::wait_sample(std::int64_t ms, std::chrono::milliseconds timeout,
                                               bool last) {
    return waited(*state_->owner, *state_, detail::wait_type(false, last, timeout.count()),
                  detail::time_content(ms), true, timeout);
}

stream_lock stream::lock(std::uint64_t first, std::uint64_t last) {
    auto& s = *state_->owner;
    require_typed(s, "LOCK_SAMPLES");
    if (first > last) throw error(errc::api_misuse, "a lock range needs first <= last");
    message reply = asked(s, *state_, "LOCK_SAMPLES", "LOCKED",
                          std::to_string(first) + "-" + std::to_string(last));
    return stream_lock(this, detail::integer_of(reply, "lock id"), first, last);
}

void stream::unlock(std::uint64_t lock_id) {
    require_typed(*state_->owner, "UNLOCK_SAMPLES");
    (void)asked(*state_->owner, *state_, "UNLOCK_SAMPLES", "RECEIVE_ACCEPT",
                std::to_string(lock_id));
}

// -- stream_lock ----------------------------------------------------------------------------------

stream_lock::stream_lock(stream_lock&& other) noexcept
    : owner_(other.owner_), id_(other.id_), first_(other.first_), last_(other.last_) {
    other.owner_ = nullptr;
}

stream_lock& stream_lock::operator=(stream_lock&& other) noexcept {
    if (this != &other) {
        if (owner_ != nullptr) {
            try {
                owner_->unlock(id_);
            } catch (...) {  // a lock that cannot be released ends with its connection
            }
        }
        owner_ = other.owner_;
        id_ = other.id_;
        first_ = other.first_;
        last_ = other.last_;
        other.owner_ = nullptr;
    }
    return *this;
}

stream_lock::~stream_lock() noexcept {
    if (owner_ == nullptr) return;
    try {
        owner_->unlock(id_);
    } catch (...) {  // never throw from a destructor; the server releases it with the connection
    }
}

void stream_lock::unlock() {
    if (owner_ == nullptr) return;
    stream* owner = owner_;
    owner_ = nullptr;
    owner->unlock(id_);
}

std::uint64_t stream_lock::release() noexcept {
    owner_ = nullptr;
    return id_;
}

// -- stream_subscription --------------------------------------------------------------------------

std::optional<received_sample> stream_subscription::next(std::chrono::milliseconds timeout) {
    auto& st = *state_;
    auto& s = *st.owner;
    if (s.in_callback) throw error(errc::api_misuse, "next() called from inside a callback");
    auto deadline = steady::now() + timeout;
    while (st.queue.empty()) {
        if (st.ended && OPENAIR_FAULT(push_end_silent)) return std::nullopt;  // test-only fault
        if (st.ended) throw *st.ended;
        if (steady::now() >= deadline) return std::nullopt;
        s.pump(deadline);
    }
    received_sample got = std::move(st.queue.front());
    st.queue.pop_front();
    s.release_held(st);
    return got;
}

void stream_subscription::on_sample(std::function<void(const received_sample&)> callback) {
    state_->callback = std::move(callback);
}

void stream_subscription::close() noexcept {
    auto& st = *state_;
    st.closed = true;
    if (detail::connection* c = st.owner->find(st.conn_id)) {
        c->dead = true;
        c->fd.reset();
        c->sess.close();
    }
    if (!st.ended) st.ended = error(errc::connection_closed, "the subscription was closed");
}

bool stream_subscription::active() const noexcept {
    detail::connection* c = state_->owner->find(state_->conn_id);
    return c != nullptr && !c->dead && !state_->ended;
}

const std::string& stream_subscription::target() const noexcept { return state_->target; }
std::uint64_t stream_subscription::received() const noexcept { return state_->received; }
std::uint64_t stream_subscription::dropped() const noexcept { return state_->dropped; }

}  // namespace openair
