// The OpenAIR module/client over TCP (spec sections 6-9, 15). No hidden threads: everything,
// callbacks included, runs on the thread that calls into the client.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "openair/content.hpp"
#include "openair/error.hpp"
#include "openair/frame.hpp"
#include "openair/message.hpp"
#include "openair/session.hpp"
#include "openair/stream.hpp"

namespace openair {

inline constexpr const char* aircentral = "AIRCentral";
inline constexpr const char* cns = "CNS";

/// TLS on the connections the client opens to the server (secure mode, OA-AUTH-10).
struct tls_options {
    bool enabled = false;
    /// PEM file of the CA certificates that the server's certificate must chain to; empty: the
    /// system's trust store.
    std::string ca_file;
    /// Require the certificate to name `client_options::host` (a DNS name or an IP address).
    bool verify_host = true;
};

/// How a client connects and behaves. Only `name` is required for a module.
struct client_options {
    std::string host = "127.0.0.1";
    std::uint16_t port = 10000;
    std::string name;
    /// Bind the name at the server (BIND or BIND_NOLISTEN); false makes a plain client.
    bool bind = true;
    /// BIND and accept deliveries on the BIND_ACCEPT port; false sends BIND_NOLISTEN (OA-SESS-5).
    bool listen = true;
    /// Open the callback connection (a `Receive` frame, OA-SESS-7).
    bool callback = true;
    /// Extensions the client may declare (the server must also advertise them, OA-GEN-2);
    /// nullopt means every extension this client implements (`client_extensions()`).
    std::optional<std::vector<std::string>> extensions;
    /// Post `Psyclone.Module.Connect.<name>` after binding, as JavaOpenAIR does (spec 6.9).
    bool announce = true;
    /// How long a request waits for its reply (OA-SESS-27: at least 10 s is advised).
    std::chrono::milliseconds request_timeout{10000};
    /// Re-establish a lost primary connection, with backoff between the two delays.
    bool reconnect = true;
    std::chrono::milliseconds reconnect_delay{50};
    std::chrono::milliseconds reconnect_max_delay{2000};
    /// Send KEEPALIVE after this long without traffic on the primary connection (OA-KEEP-1);
    /// zero disables it.
    std::chrono::milliseconds keepalive{60000};
    /// How long a started frame may stall before the connection is dropped (OA-FRAME-12).
    std::chrono::milliseconds frame_deadline{30000};
    frame_limits limits;
    /// The clock used to stamp postedTime, in ns since the epoch; empty means the system clock.
    clock_function clock;
    /// The module's secret (any bytes) for secure mode (extension `auth`, spec 14.3). When set,
    /// every connection the client opens proves `name` (AUTH_CHALLENGE, AUTH_RESPONSE with an
    /// HMAC-SHA256 proof) before it binds or acts, and `connect` throws AUTH_REQUIRED at a
    /// server that does not advertise `auth` (OA-AUTH-12). Only the proof is ever sent; the
    /// secret is never sent, printed nor put into an error.
    std::optional<std::string> secret;
    /// TLS on every connection to the server; off by default.
    tls_options tls;
};

/// Where a delivery arrived (OA-DELIV-1).
enum class delivery_path { callback, listener };

/// A wakeup delivered to the module. A phase update has `wakeup.trigger` empty (OA-WAKE-8).
struct wakeup_event {
    openair::wakeup wakeup;
    message msg;               ///< the AIR.Instruct.Wakeup itself
    std::int64_t received_ns;  ///< read from the clock when its bytes arrived
    delivery_path path;
};

/// Any other message delivered to the module (forwarded to it by name, OA-SESS-22).
struct message_event {
    message msg;
    std::int64_t received_ns;
    delivery_path path;
};

/// Options of a post besides its addressee, type and content.
struct post_options {
    std::vector<std::string> cc;  ///< modules to wake whatever their triggers (OA-CC-1)
    std::optional<double> priority;
    std::string language;
    bool content_is_xml = false;
    std::vector<std::string> binary;  ///< chunks sent after the XML (OA-FRAME-4): attachments
};

/// REQUEST_FAILED: the peer answered a request with a failure reply (OA-GEN-3).
class request_failed : public error {
public:
    request_failed(message request, message reply);
    [[nodiscard]] const message& request() const noexcept { return request_; }
    [[nodiscard]] const message& reply() const noexcept { return reply_; }
    /// The condition a `NAME: detail` content names, if it names one a peer may send
    /// (OA-ERR-2, OA-ERR-7, OA-ERR-8).
    [[nodiscard]] std::optional<errc> condition() const;

private:
    message request_;
    message reply_;
};

/// An OpenAIR module (or, with `bind = false`, a plain client) connected to one server.
///
/// Threading: a client is used from one thread at a time. It starts no thread. Requests block
/// the calling thread until their reply arrives (or `request_timeout`), servicing every
/// connection of the client meanwhile. Deliveries (wakeups, forwarded messages) are read and
/// queued whenever the client waits; they are handed to the callbacks only by `poll`, on the
/// caller's thread, and each is acknowledged after its callback returned (OA-DELIV-4). PING
/// and KEEPALIVE are answered without a callback (OA-SESS-11). Call `poll` regularly.
class client {
public:
    /// Connect, ask GET_CAPABILITIES (UNKNOWN_COMMAND: legacy, OA-CAP-2), bind, listen, open
    /// the callback connection and announce, as configured. Throws CONNECTION_CLOSED when the
    /// server cannot be reached (or its TLS certificate is not trusted), REQUEST_FAILED when it
    /// refuses the BIND, REQUEST_TIMEOUT; with a `secret`, AUTH_REQUIRED at a server without
    /// `auth` and AUTH_FAILED when it refuses the proof.
    [[nodiscard]] static client connect(client_options options);

    client(client&& other) noexcept;
    client& operator=(client&& other) noexcept;
    client(const client&) = delete;
    client& operator=(const client&) = delete;
    ~client() noexcept;

    void on_wakeup(std::function<void(const wakeup_event&)> callback);
    void on_message(std::function<void(const message_event&)> callback);
    /// Called with the reason each time a delivery cannot be read (its frame, its envelope or a
    /// wakeup's content) and is therefore lost; it is answered RECEIVE_ERROR as OA-SESS-11
    /// requires and counted in `undecodable_deliveries` (OA-MSG-20). Without a callback the
    /// reason is written to std::clog. Runs while the client reads: it must not call the client.
    void on_dropped_delivery(std::function<void(const std::string& reason)> callback);
    /// Called by `poll` for each stream sample a registration brings (`subscribe(…, streams)`,
    /// OA-STREAM-14); acknowledged after the callback returned, like a wakeup.
    void on_sample(std::function<void(const received_sample&)> callback);

    /// Wait up to `timeout` for deliveries and hand every queued one to its callback; return
    /// how many were handed over. Also keeps the session alive (KEEPALIVE) and reconnects a
    /// lost primary connection when `reconnect` is set. A callback's exception propagates
    /// after its delivery was acknowledged. API_MISUSE when called from inside a callback.
    std::size_t poll(std::chrono::milliseconds timeout);

    /// Post a message and wait for RECEIVE_ACCEPT (OA-WB-3); return it as sent. The type is
    /// validated first (TYPE_INVALID); a failure reply throws `request_failed`.
    message post(const std::string& to, const std::string& type, const std::string& content = "",
                 const post_options& options = {});
    /// Post without waiting: `noreply="yes"` when the server advertised `noreply` (OA-MSG-15);
    /// otherwise an ordinary post whose reply is read and dropped (OA-GEN-2).
    message post_noreply(const std::string& to, const std::string& type,
                         const std::string& content = "", const post_options& options = {});
    /// Post several messages, pipelined when the server advertised `pipelining` (OA-SESS-17),
    /// in order; a message without `from` gets the module's name. Every reply is awaited; the
    /// first failure is thrown afterwards.
    std::vector<message> post_many(std::vector<message> messages);
    /// Replace the module's registration (OA-REG-1) with AIR.Subscribe in the module form
    /// (OA-REG-3) to AIRCentral; it is sent again after a reconnect. Patterns are validated
    /// first (PATTERN_INVALID).
    /// `streams` names streams (by name, type or type pattern) whose samples the registration
    /// brings as deliveries: each an `<inputstream source="S">` (OA-STREAM-14), handed to
    /// `on_sample`.
    void subscribe(std::vector<trigger> triggers, std::vector<retrieve_spec> retrieves = {},
                   bool allow_self_triggering = false, std::vector<std::string> streams = {});
    /// Retrieve stored messages, newest first (OA-RET-6): AIR.Retrieve for one spec,
    /// AIR.Retrieves for several (OA-RET-1).
    [[nodiscard]] std::vector<message> retrieve(const std::vector<retrieve_spec>& specs,
                                                const std::string& to = aircentral);
    [[nodiscard]] std::vector<message> retrieve(const retrieve_spec& spec,
                                                const std::string& to = aircentral);
    /// Send any request as is (postedTime stamped, empty `from` and `id` filled in) and return
    /// its reply, uninterpreted.
    [[nodiscard]] message request(message msg);
    /// Drop the primary connection and establish the session again (bind, registration,
    /// `Psyclone.Module.Reconnect.<name>`).
    void reconnect();
    /// Close every connection; later requests throw CONNECTION_CLOSED.
    void close() noexcept;

    // -- streams (spec section 11; stream.hpp) ------------------------------------------------
    /// The handle of the stream named (or, under typed-streams, typed) `target`: one per target,
    /// owned by the client. Its connection opens on first use.
    [[nodiscard]] openair::stream& stream(const std::string& target);
    /// Open a push subscription to a stream (RECEIVE_NAME_NOTIFICATION on a connection of its
    /// own, OA-STREAM-8) and wait until the server counts it (GET_INFO `subscribers`).
    /// STREAM_UNKNOWN when the server refuses it. Owned by the client.
    [[nodiscard]] stream_subscription& subscribe_stream(const std::string& target,
                                                        std::size_t buffer = 100);
    /// Subscribe to stream alarms matching `pattern` (on `whiteboard`, default any) through a
    /// companion module (OA-XSTREAM-6).
    [[nodiscard]] alarm_subscription alarms(const std::string& pattern = std::string(alarm_pattern),
                                            const std::string& whiteboard = "");
    /// Every stream of the server (GET_STREAMS to CNS, OA-STREAM-16).
    [[nodiscard]] std::vector<stream_info> list_streams();

    [[nodiscard]] bool connected() const noexcept;
    /// True when the server answered GET_CAPABILITIES with anything but CAPABILITIES.
    [[nodiscard]] bool legacy() const noexcept;
    [[nodiscard]] const std::optional<capabilities>& server_capabilities() const noexcept;
    /// The extensions in use: declared by this client and advertised by the server.
    [[nodiscard]] const std::set<std::string>& extensions() const noexcept;
    /// The port of BIND_ACCEPT (-1 for BIND_NOLISTEN or when not bound).
    [[nodiscard]] int bound_port() const noexcept;
    /// The port the module listens on for deliveries, if it listens.
    [[nodiscard]] std::optional<std::uint16_t> listen_port() const noexcept;
    /// How many times the session was established (1 after `connect`).
    [[nodiscard]] unsigned generation() const noexcept;
    /// How many deliveries could not be read and were lost (OA-MSG-20).
    [[nodiscard]] std::uint64_t undecodable_deliveries() const noexcept;
    [[nodiscard]] const std::string& name() const noexcept;

private:
    friend class openair::stream;
    friend class stream_subscription;
    friend class stream_lock;
    friend struct detail::stream_state;
    friend struct detail::subscription_state;
    struct impl;
    explicit client(std::unique_ptr<impl> state) noexcept;
    impl& self() const;
    std::unique_ptr<impl> impl_;
};

}  // namespace openair
