// The client side of one OpenAIR connection, without I/O (spec section 6), h11-style: calls
// become bytes to send, received bytes become events. No socket, no thread, no clock read
// except through the clock function given, and only as the last act before encoding (OA-TIME-2).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "openair/datasample.hpp"
#include "openair/error.hpp"
#include "openair/frame.hpp"
#include "openair/message.hpp"

namespace openair {

/// The extensions this client implements (OA-EXT-1); a module declares a subset (OA-SESS-19).
[[nodiscard]] const std::set<std::string>& client_extensions();

inline constexpr std::size_t default_max_in_flight = 256;  // OA-LIM-5

/// The acknowledgement a module sends for a delivery of type `request_type` (OA-SESS-11,
/// OA-DELIV-4): PING_SUCCESS, KEEPALIVESUCCESS or RECEIVE_ACCEPT.
[[nodiscard]] std::string_view default_answer(std::string_view request_type) noexcept;

/// Which side of the request/reply pairing this end of the connection is (OA-SESS-28).
enum class role { requester, responder };
enum class session_state { requester, responder, closed, failed };

/// A reply, paired with the request it answers (OA-SESS-33).
struct reply_event {
    std::string request_id;
    message msg;
};
/// A request the peer sent (a wakeup, PING, KEEPALIVE or forwarded message). Answer it with
/// `session::answer(seq)` unless `needs_answer` is false (a `noreply` delivery, OA-MSG-15).
struct request_event {
    std::uint64_t seq = 0;
    message msg;
    bool needs_answer = true;
};
/// A correctly framed request whose message could not be read; answer it (OA-ERR-3).
struct invalid_event {
    std::uint64_t seq = 0;
    error failure;
};
/// The peer closed the connection cleanly; `unanswered` are the ids of requests left without
/// a reply.
struct closed_event {
    std::vector<std::string> unanswered;
};
/// The peer broke the protocol; the connection is failed for good (OA-FRAME-9). Always the
/// last event; every later `receive_*` call throws the same error.
struct failed_event {
    error failure;
};
using session_event =
    std::variant<reply_event, request_event, invalid_event, closed_event, failed_event>;

/// Nanoseconds since the Unix epoch.
using clock_function = std::function<std::int64_t()>;
/// The system clock (`std::chrono::system_clock`) in nanoseconds since the epoch.
[[nodiscard]] std::int64_t system_clock_ns();

/// Bytes to write and the message as it was encoded (with its postedTime).
struct outgoing {
    std::string bytes;
    message sent;
};

/// One connection of an OpenAIR module or client, as a sans-I/O state machine.
///
/// As REQUESTER (a connection this side opened) it sends requests and every frame it receives
/// is a reply, paired with the oldest unanswered request (OA-SESS-33). As RESPONDER (a
/// connection the server opened to the listening port, or a callback connection after its
/// `Receive` frame) every frame it receives is a request, answered in arrival order
/// (OA-SESS-2, OA-SESS-11). `window` bounds the requests in flight: 1 for a legacy server
/// (OA-SESS-18), up to `max-in-flight` with `pipelining` (OA-SESS-17).
class session {
public:
    explicit session(role r = role::requester, clock_function now = system_clock_ns,
                     std::size_t window = 1, std::set<std::string> extensions = {},
                     std::string name = "", frame_limits limits = {});

    [[nodiscard]] session_state state() const noexcept { return state_; }
    [[nodiscard]] std::size_t in_flight() const noexcept { return in_flight_.size(); }
    /// True when a request may be sent now without exceeding the window.
    [[nodiscard]] bool can_send() const noexcept {
        return state_ == session_state::requester && in_flight_.size() < window_;
    }
    /// How many received requests still wait for `answer`.
    [[nodiscard]] std::size_t unanswered() const noexcept { return to_answer_.size(); }
    /// True while part of a frame is held (the adapter times the frame deadline, OA-FRAME-12).
    [[nodiscard]] bool in_frame() const noexcept { return reader_.in_frame(); }
    [[nodiscard]] const std::optional<error>& failure() const noexcept { return error_; }

    [[nodiscard]] std::size_t window() const noexcept { return window_; }
    void set_window(std::size_t window);
    [[nodiscard]] const std::set<std::string>& extensions() const noexcept { return extensions_; }
    void set_extensions(std::set<std::string> extensions) { extensions_ = std::move(extensions); }
    [[nodiscard]] const std::string& name() const noexcept { return name_; }

    /// The frame for request `msg`, stamped with postedTime (OA-TIME-2). A `noreply` message
    /// (only under the `noreply` extension, OA-GEN-2) expects no reply and takes no window
    /// slot. Throws API_MISUSE when the window is full (OA-SESS-18) or on a responder
    /// connection (OA-SESS-28), CONNECTION_CLOSED when closed.
    [[nodiscard]] outgoing send_request(message msg);
    /// As `send_request`, with the binary chunks given as parts (`msg.binary` must be empty):
    /// `binarysizes` is written from the parts and each payload is copied once, into the bytes
    /// returned (ADD_SAMPLE, ADD_SAMPLES, OA-FRAME-4).
    [[nodiscard]] outgoing send_request_parts(message msg, const std::vector<chunk_parts>& chunks);
    /// A `BinaryM` frame carrying one chunk and no XML (OA-FRAME-5): on a connection whose
    /// current stream is set it is an ADD_SAMPLE answered with an empty `isresponse`
    /// (OA-STREAM-11), so it takes a window slot like any request.
    [[nodiscard]] std::string send_binary(const chunk_parts& chunk);
    /// The `Receive` frame that makes this a callback connection (OA-SESS-7); no reply follows,
    /// and from then on the peer is the requester (OA-SESS-28).
    [[nodiscard]] outgoing send_notification(message msg);
    /// The frame answering request `seq`, which must be the oldest unanswered one (OA-SESS-2).
    /// The default type is `default_answer(...)`, and RECEIVE_ERROR with `NAME: detail` for an
    /// invalid request (OA-ERR-2, OA-ERR-3); `isresponse` is the request's id (OA-SESS-1).
    [[nodiscard]] std::string answer(std::uint64_t seq, std::string_view type = {},
                                     std::string_view content = {});
    /// Feed received bytes and return the events they complete (OA-FRAME-11). After a
    /// `failed_event`, every later call throws that error (OA-FRAME-9).
    [[nodiscard]] std::vector<session_event> receive_data(std::string_view data);
    /// The peer closed: a `closed_event`, or a `failed_event` with FRAME_TRUNCATED when the
    /// stream ended inside a frame (OA-FRAME-8).
    [[nodiscard]] std::vector<session_event> receive_eof();
    /// Mark the connection closed by this side; later sends throw CONNECTION_CLOSED.
    void close() noexcept;

private:
    enum class action {
        send_request,
        send_notification,
        receive,
        answer,
        peer_closed,
        close,
        fail
    };
    struct pending_answer {
        std::uint64_t seq;
        std::optional<message> request;  // nullopt for an invalid request
        std::optional<error> failure;
    };

    void transition(action a);
    void check_send(bool noreply) const;
    [[nodiscard]] message stamp(message msg) const;
    [[nodiscard]] session_event event_for(const frame& f);
    [[nodiscard]] failed_event fail(const error& e);

    session_state state_;
    clock_function now_;
    std::size_t window_;
    std::set<std::string> extensions_;
    std::string name_;
    frame_reader reader_;
    std::deque<std::string> in_flight_;  // ids of requests sent and not answered yet
    std::deque<pending_answer> to_answer_;
    std::uint64_t next_seq_ = 1;
    std::optional<error> error_;
};

}  // namespace openair
