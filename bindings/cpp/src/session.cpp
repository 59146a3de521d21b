// The sans-I/O session of one connection (spec section 6). State changes follow one table.
#include "openair/session.hpp"

#include <chrono>
#include <limits>
#include <map>
#include <utility>

#include "codec_internal.hpp"
#include "openair/codec.hpp"
#include "openair/content.hpp"
#include "test_faults.hpp"

namespace openair {

namespace {

using st = session_state;

const char* state_name(st s) {
    switch (s) {
        case st::requester: return "requester";
        case st::responder: return "responder";
        case st::closed: return "closed";
        case st::failed: return "failed";
    }
    return "?";
}

}  // namespace

const std::set<std::string>& client_extensions() {
    static const std::set<std::string> names = {"gettime", "noreply", "pipelining", "usec"};
    return names;
}

std::string_view default_answer(std::string_view request_type) noexcept {
    // OA-SESS-10 (test-only fault ping_accept: the wrong answer, for openair-shim-broken)
    if (request_type == "PING" && !OPENAIR_FAULT(ping_accept)) return "PING_SUCCESS";
    if (request_type == "KEEPALIVE") return "KEEPALIVESUCCESS";  // OA-KEEP-2
    return "RECEIVE_ACCEPT";                                     // OA-DELIV-4
}

std::int64_t system_clock_ns() {
    using namespace std::chrono;
    return duration_cast<nanoseconds>(system_clock::now().time_since_epoch()).count();
}

session::session(role r, clock_function now, std::size_t window, std::set<std::string> extensions,
                 std::string name, frame_limits limits)
    : state_(r == role::requester ? st::requester : st::responder),
      now_(now ? std::move(now) : clock_function(system_clock_ns)),
      window_(window),
      extensions_(std::move(extensions)),
      name_(std::move(name)),
      reader_(limits) {
    if (window_ < 1) throw error(errc::api_misuse, "window must be at least 1");
}

void session::set_window(std::size_t window) {
    if (window < 1) throw error(errc::api_misuse, "window must be at least 1");
    window_ = window;
}

void session::transition(action a) {
    // (state, action) -> next state; a missing entry is misuse (style: state machines are tables).
    static const std::map<std::pair<st, action>, st> table = {
        {{st::requester, action::send_request}, st::requester},
        {{st::requester, action::send_notification}, st::responder},  // OA-SESS-7, -28
        {{st::requester, action::receive}, st::requester},
        {{st::requester, action::peer_closed}, st::closed},
        {{st::requester, action::close}, st::closed},
        {{st::requester, action::fail}, st::failed},
        {{st::responder, action::receive}, st::responder},
        {{st::responder, action::answer}, st::responder},
        {{st::responder, action::peer_closed}, st::closed},
        {{st::responder, action::close}, st::closed},
        {{st::responder, action::fail}, st::failed},
        {{st::closed, action::receive}, st::closed},
        {{st::closed, action::peer_closed}, st::closed},
        {{st::closed, action::close}, st::closed},
        {{st::failed, action::close}, st::failed},
        {{st::failed, action::peer_closed}, st::failed},
    };
    auto it = table.find({state_, a});
    if (it != table.end()) {
        state_ = it->second;
        return;
    }
    if (state_ == st::closed) throw error(errc::connection_closed, "the connection is closed");
    if (state_ == st::failed) {
        throw error(errc::connection_closed,
                    std::string("the connection failed: ") + error_->what());
    }
    throw error(errc::api_misuse, std::string("not allowed in state ") + state_name(state_));
}

message session::stamp(message msg) const {
    if (OPENAIR_FAULT(no_posted_time)) return msg;  // test-only fault (openair-shim-broken)
    // OA-TIME-2: postedTime is the last act before encoding; usec only under `usec` (OA-TIME-5).
    msg.posted = air_time::from_ns(now_(), extensions_.count("usec") != 0);
    return msg;
}

void session::check_send(bool noreply) const {
    if (state_ == st::requester) {
        if (noreply && extensions_.count("noreply") == 0) {
            throw error(errc::api_misuse, "noreply needs the noreply extension");  // OA-GEN-2
        }
        if (!noreply && in_flight_.size() >= window_) {  // OA-SESS-18, OA-LIM-7
            throw error(errc::api_misuse,
                        std::to_string(window_) + " request(s) already in flight");
        }
    }
    if (state_ == st::responder) {
        throw error(errc::api_misuse, "a responder connection sends only replies");  // OA-SESS-28
    }
}

namespace {

void append_header(std::string& out, frame_tag tag, std::uint64_t length) {
    if (length > std::numeric_limits<std::uint32_t>::max()) {
        throw error(errc::api_misuse, "a frame body of " + std::to_string(length) +
                                          " bytes does not fit the uint32 length");
    }
    out += frame_tag_name(tag);
    out += '\0';  // OA-FRAME-1
    for (int i = 0; i < 4; ++i) out += static_cast<char>((length >> (8 * i)) & 0xFF);  // OA-FRAME-3
}

void append_chunk(std::string& out, const chunk_parts& chunk) {
    out += chunk.head;
    out += chunk.payload.chars();
    out += chunk.tail;
}

}  // namespace

outgoing session::send_request_parts(message msg, const std::vector<chunk_parts>& chunks) {
    if (!msg.binary.empty()) {
        throw error(errc::api_misuse, "send_request_parts takes its chunks apart, not in binary");
    }
    check_send(msg.noreply);
    message stamped = stamp(std::move(msg));
    std::vector<std::uint64_t> sizes;
    std::uint64_t total = 0;
    for (const chunk_parts& c : chunks) {
        sizes.push_back(c.size());
        total += c.size();
    }
    std::string xml;
    detail::write_message(xml, stamped, &sizes);  // binarysizes from the parts (OA-FRAME-4)
    std::string bytes;
    bytes.reserve(frame_header_size + xml.size() + total);
    append_header(bytes, frame_tag::message, xml.size());
    bytes += xml;
    for (const chunk_parts& c : chunks) append_chunk(bytes, c);  // the one copy of the payload
    transition(action::send_request);
    if (!stamped.noreply) in_flight_.push_back(stamped.id);
    return {std::move(bytes), std::move(stamped)};
}

std::string session::send_binary(const chunk_parts& chunk) {
    check_send(false);
    std::string bytes;
    bytes.reserve(frame_header_size + chunk.size());
    append_header(bytes, frame_tag::binary, chunk.size());  // OA-FRAME-5
    append_chunk(bytes, chunk);
    transition(action::send_request);
    in_flight_.emplace_back();  // OA-STREAM-11: answered with an empty isresponse
    return bytes;
}

outgoing session::send_request(message msg) {
    if (state_ == st::requester) {
        if (msg.noreply && extensions_.count("noreply") == 0) {
            throw error(errc::api_misuse, "noreply needs the noreply extension");  // OA-GEN-2
        }
        if (!msg.noreply && in_flight_.size() >= window_) {  // OA-SESS-18, OA-LIM-7
            throw error(errc::api_misuse,
                        std::to_string(window_) + " request(s) already in flight");
        }
    }
    if (state_ == st::responder) {
        throw error(errc::api_misuse, "a responder connection sends only replies");  // OA-SESS-28
    }
    message stamped = stamp(std::move(msg));
    std::string bytes = encode_frame(to_frame(stamped));
    transition(action::send_request);
    if (!stamped.noreply) in_flight_.push_back(stamped.id);
    return {std::move(bytes), std::move(stamped)};
}

outgoing session::send_notification(message msg) {
    if (state_ == st::requester && !in_flight_.empty()) {
        throw error(errc::api_misuse, "cannot turn a connection with requests in flight around");
    }
    message stamped = stamp(std::move(msg));
    std::string bytes = encode_frame(to_frame(stamped, frame_tag::receive));
    transition(action::send_notification);
    return {std::move(bytes), std::move(stamped)};
}

std::string session::answer(std::uint64_t seq, std::string_view type, std::string_view content) {
    if (state_ == st::responder && (to_answer_.empty() || to_answer_.front().seq != seq)) {
        throw error(errc::api_misuse, "answer the oldest unanswered request first (OA-SESS-2)");
    }
    transition(action::answer);
    pending_answer pending = std::move(to_answer_.front());
    to_answer_.pop_front();
    message reply;
    if (!pending.request) {  // OA-ERR-3: its id could not be read, so isresponse stays empty
        reply = make_message(type.empty() ? "RECEIVE_ERROR" : std::string(type), name_);
        reply.content = content.empty() ? pending.failure->wire_text() : std::string(content);
    } else {
        std::string_view kind = type.empty() ? default_answer(pending.request->type) : type;
        reply = pending.request->reply(std::string(kind), name_, std::string(content));
        // Test-only faults (openair-shim-broken): a wakeup acknowledged wrongly, or never.
        if (OPENAIR_FAULT(wrong_isresponse) && pending.request->type == wakeup_type) {
            reply.isresponse = new_id();
        }
        if (OPENAIR_FAULT(no_ack) && pending.request->type == wakeup_type) return {};
    }
    return encode_frame(to_frame(stamp(std::move(reply))));
}

void session::close() noexcept {
    if (state_ != st::failed) state_ = st::closed;
}

failed_event session::fail(const error& e) {
    transition(action::fail);  // OA-FRAME-9: sticky
    error_ = e;
    in_flight_.clear();
    return failed_event{e};
}

std::vector<session_event> session::receive_data(std::string_view data) {
    if (error_) throw *error_;
    transition(action::receive);
    std::vector<session_event> events;
    if (state_ == st::closed) return events;  // closed by this side: late bytes are dropped
    try {
        reader_.feed(data);
        while (auto f = reader_.next()) {
            events.push_back(event_for(*f));
            if (std::holds_alternative<failed_event>(events.back())) break;
        }
    } catch (const error& e) {
        events.emplace_back(fail(e));
    }
    return events;
}

std::vector<session_event> session::receive_eof() {
    if (error_) throw *error_;
    if (state_ == st::closed) return {};
    try {
        reader_.feed_eof();                       // OA-FRAME-8: a partial frame is FRAME_TRUNCATED
        while (auto f = reader_.next()) (void)f;  // unreachable: frames are drained on receipt
    } catch (const error& e) {
        return {fail(e)};
    }
    std::vector<std::string> unanswered(in_flight_.begin(), in_flight_.end());
    in_flight_.clear();
    transition(action::peer_closed);
    return {closed_event{std::move(unanswered)}};
}

session_event session::event_for(const frame& f) {
    if (state_ == st::requester) {
        message msg;
        try {
            msg = from_frame(f, {}, true);  // OA-MSG-19: a client reads a legacy server liberally
        } catch (const error& e) {
            return fail(e);  // an unreadable reply cannot be paired: the connection is lost
        }
        if (in_flight_.empty()) {
            return fail(
                error(errc::message_invalid, "reply '" + msg.type + "' with no request in flight"));
        }
        // OA-SESS-33: an empty isresponse is accepted (Psyclone's KEEPALIVESUCCESS); one that
        // names another request means the replies are out of order (OA-SESS-2).
        if (!msg.isresponse.empty() && msg.isresponse != in_flight_.front()) {
            return fail(error(errc::message_invalid, "reply '" + msg.type + "' answers '" +
                                                         msg.isresponse + "', expected '" +
                                                         in_flight_.front() + "'"));
        }
        std::string id = std::move(in_flight_.front());
        in_flight_.pop_front();
        return reply_event{std::move(id), std::move(msg)};
    }
    std::uint64_t seq = next_seq_++;
    try {
        message msg = from_frame(f, {}, true);  // OA-MSG-19
        bool noreply = msg.noreply && extensions_.count("noreply") != 0;  // OA-MSG-15
        if (!noreply) to_answer_.push_back({seq, msg, std::nullopt});
        return request_event{seq, std::move(msg), !noreply};
    } catch (const error& e) {
        if (e.closes()) return fail(e);
        to_answer_.push_back({seq, std::nullopt, e});  // OA-ERR-3: the connection stays usable
        return invalid_event{seq, e};
    }
}

}  // namespace openair
