// Internal: the state of a client and its I/O loop (one poll(2) over every connection).
#pragma once

#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "openair/client.hpp"
#include "socket.hpp"
#include "tls_socket.hpp"

namespace openair {

using steady = std::chrono::steady_clock;

namespace detail {

/// primary, callback and accepted as before; `stream`: a stream handle's requester connection;
/// `push`: a push subscription (responder after its Receive frame, OA-STREAM-8).
enum class conn_kind { primary, callback, accepted, stream, push };

/// One TCP connection and its sans-I/O session.
struct connection {
    int id = 0;
    conn_kind kind = conn_kind::primary;
    fd_handle fd;
    /// TLS over `fd` (secure mode, OA-AUTH-10); declared after `fd`, so destroyed before it.
    std::unique_ptr<tls_stream> tls;
    session sess;
    std::string out;  // bytes not yet written
    bool dead = false;
    std::string reason;  // why it died
    steady::time_point last_rx = steady::now();
    steady::time_point last_traffic = steady::now();
    /// Requests received and not answered yet, in arrival order (OA-SESS-2).
    struct answer_slot {
        std::uint64_t seq = 0;
        bool ready = false;
        std::string type;
        std::string content;
    };
    std::deque<answer_slot> answers;
    /// Requests sent on a stream connection, awaiting replies in order (OA-SESS-33).
    std::deque<std::uint64_t> tickets;
};

/// Read or write a connection, through TLS when it has it.
inline io_result read_some(connection& c, char* buf, std::size_t size) {
    return c.tls ? c.tls->read_some(buf, size) : read_some(c.fd.get(), buf, size);
}
inline io_result write_some(connection& c, std::string_view data) {
    return c.tls ? c.tls->write_some(data) : write_some(c.fd.get(), data);
}

/// A delivery waiting for `poll` to hand it to a callback.
struct delivery {
    int conn_id = 0;
    std::uint64_t seq = 0;  // 0: nothing to acknowledge (noreply)
    std::variant<wakeup_event, message_event, received_sample> event;
};

/// A stream handle's state (stream.hpp): its target, its connection and its learnt name.
struct stream_state {
    client::impl* owner = nullptr;
    std::string target;
    std::string name;
    int conn_id = 0;  // 0: not open
    std::unique_ptr<openair::stream> handle;
};

/// A push subscription's state: its connection, the local buffer, how it ended.
struct subscription_state {
    client::impl* owner = nullptr;
    std::string target;
    int conn_id = 0;
    std::size_t buffer = 100;
    std::deque<received_sample> queue;
    std::deque<std::uint64_t> held;  // DATASAMPLEs not acknowledged yet (the buffer was full)
    std::function<void(const received_sample&)> callback;
    std::optional<error> ended;  // set when the push connection ended (or was refused)
    bool closed = false;
    std::uint64_t received = 0;
    std::uint64_t dropped = 0;
    std::unique_ptr<stream_subscription> handle;
};

}  // namespace detail

struct client::impl {
    client_options opt;
    std::function<void(const wakeup_event&)> on_wakeup;
    std::function<void(const message_event&)> on_message;
    std::function<void(const std::string&)> on_dropped;
    std::uint64_t undecodable = 0;  // deliveries that could not be read (OA-MSG-20)

    std::unique_ptr<detail::connection> primary;
    std::unique_ptr<detail::connection> callback;
    std::vector<std::unique_ptr<detail::connection>> accepted;
    std::vector<std::unique_ptr<detail::connection>> extra;  // stream and push connections
    std::map<std::string, std::unique_ptr<detail::stream_state>> streams;
    std::vector<std::unique_ptr<detail::subscription_state>> subscriptions;
    std::function<void(const received_sample&)> on_sample;
    std::unique_ptr<detail::tls_context> tls;  // set when `opt.tls.enabled`
    detail::fd_handle listener;
    std::optional<std::uint16_t> listening_port;
    int next_conn_id = 1;

    // Requests on the primary connection: tickets in send order, and their outcome.
    std::deque<std::uint64_t> tickets;
    std::map<std::uint64_t, std::variant<std::monostate, message, error>> outcomes;
    std::set<std::uint64_t> dropped;  // fire-and-forget: the reply is read and dropped
    std::uint64_t next_ticket = 1;

    std::deque<detail::delivery> inbox;
    bool in_callback = false;
    bool closed = false;
    bool started = false;

    std::optional<capabilities> caps;
    bool legacy = false;
    std::set<std::string> wanted;
    std::set<std::string> extensions;
    int bound_port = -1;
    unsigned generation = 0;
    struct registration {
        std::vector<trigger> triggers;
        std::vector<retrieve_spec> retrieves;
        bool allow_self_triggering = false;
        std::vector<std::string> streams;
    };
    std::optional<registration> reg;
    steady::time_point next_attempt = steady::now();
    std::chrono::milliseconds backoff{0};

    explicit impl(client_options o);

    // -- client_io.cpp: the loop ------------------------------------------------------------
    std::int64_t now_ns() const;
    std::unique_ptr<detail::connection> open(detail::conn_kind kind, role r);
    /// Wait for I/O until `deadline` (one poll(2) round) and handle what arrived.
    void pump(steady::time_point deadline);
    void flush(detail::connection& c);
    void drop(detail::connection& c, const std::string& reason);
    void primary_lost(const std::string& reason);
    void handle_data(detail::connection& c, std::string_view data);
    void handle_event(detail::connection& c, session_event& event, std::int64_t received_ns);
    void queue_delivery(detail::connection& c, request_event& req, std::int64_t received_ns);
    /// Count and report a delivery that cannot be read: never lose one silently (OA-MSG-20).
    void delivery_dropped(const std::string& reason);
    void answer_ready(detail::connection& c);
    void reap();
    detail::connection* find(int id);

    // -- client.cpp: requests and the session ---------------------------------------------------
    std::pair<message, std::uint64_t> submit(message msg, steady::time_point deadline);
    message wait(std::uint64_t ticket, steady::time_point deadline);
    std::pair<message, message> request(message msg);
    void ensure_connected(steady::time_point deadline);
    void establish(bool first);
    void negotiate();
    void bind_and_receive();
    void send_registration();
    void announce(bool first);
    message declare(message msg) const;
    void maintain();
    std::size_t dispatch();
    void close_all() noexcept;

    // -- client_auth.cpp: secure mode (extension `auth`, spec 14.3) ----------------------------
    /// Refuse to go on at a server that does not advertise `auth` (OA-AUTH-12).
    void require_auth() const;
    /// Prove the module's name on the primary connection (OA-AUTH-2, OA-AUTH-3).
    void prove_primary();
    /// Prove the module's name on a new connection before its first frame (OA-AUTH-4,
    /// OA-AUTH-6): a blocking exchange on that connection alone.
    void prove_on(detail::connection& c);
    message exchange_on(detail::connection& c, message msg, steady::time_point deadline);

    // -- client_streams.cpp: stream connections and push subscriptions ---------------------------
    /// The handle's connection, opened (and named with GET_NAME) when needed.
    detail::connection& stream_conn(detail::stream_state& st);
    /// Send a request on a stream connection (waiting for a window slot); its ticket (0 for a
    /// noreply request).
    std::uint64_t submit_on(detail::connection& c, message msg,
                            const std::vector<chunk_parts>* chunks, steady::time_point deadline);
    std::uint64_t submit_binary(detail::connection& c, const chunk_parts& chunk,
                                steady::time_point deadline);
    /// Wait for the reply of a ticket on a stream connection.
    message wait_on(int conn_id, std::uint64_t ticket, steady::time_point deadline);
    /// One media command on the handle's connection, answered by its reply.
    std::pair<message, message> media(detail::stream_state& st, message msg,
                                      std::chrono::milliseconds extra_wait = {});
    void queue_push(detail::connection& c, request_event& req, std::int64_t received_ns);
    void release_held(detail::subscription_state& sub);
    void subscription_ended(int conn_id, const std::string& reason);
    detail::subscription_state* subscription_of(int conn_id);
    std::size_t dispatch_subscriptions();
    /// Whether a subscription with a callback has samples for `poll` to hand over.
    bool subscription_waiting() const;
};

}  // namespace openair
