// Streams from the client side (spec section 11): write, read, wait, search, lock, push
// subscriptions and alarms. No hidden threads: every call runs on the caller's thread and keeps
// all of the client's connections serviced while it waits (client.hpp, "Threading").
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "openair/datasample.hpp"
#include "openair/message.hpp"

namespace openair {

class client;

namespace detail {
struct stream_state;
struct subscription_state;
}  // namespace detail

/// The alarm types a typed stream posts (OA-XSTREAM-6), as a trigger pattern.
inline constexpr std::string_view alarm_pattern = "AIR.Stream.Alarm.*";

/// What a writer adds besides the payload: its own parameters (in order), `builtin:timestamp`
/// (else the stream stamps the time of receipt, OA-STREAM-4) and `builtin:seq` (gap detection,
/// OA-XSTREAM-8). Both builtins replace a parameter of the same key in place, else come last.
struct sample_options {
    sample_params params;
    std::optional<std::int64_t> timestamp_ms;
    std::optional<std::int64_t> seq;
};

/// A sample pushed to the client: by a push subscription or a registration (OA-STREAM-14).
struct received_sample {
    std::string stream;          ///< the stream's name (the DATASAMPLE's `from`)
    data_sample sample;          ///< owns the received chunk; its payload is a view into it
    std::uint64_t dropped = 0;   ///< samples the server dropped before this one (OA-STREAM-8)
    std::int64_t received_ns = 0;  ///< read from the clock when its bytes arrived
};

/// One `<streaminfo>` (GET_INFO, spec 11.4). Sizes are in bytes.
struct stream_info {
    std::string name;
    std::string whiteboard;
    std::string type;  ///< empty for an untyped stream
    std::uint64_t count = 0;
    std::uint64_t size = 0;
    std::optional<std::uint64_t> oldest;  ///< ids; absent when the stream is empty
    std::optional<std::uint64_t> newest;
    std::uint64_t maxsize = 0;
    std::uint64_t maxcount = 0;
    std::optional<std::uint64_t> softsize, softcount, hardsize, hardcount, idle;
    std::uint64_t subscribers = 0;
    std::uint64_t writers = 0;
    std::uint64_t locked = 0;
};

/// An alarm a typed stream posted (OA-XSTREAM-6): `AIR.Stream.Alarm.<kind>`.
struct stream_alarm {
    std::string kind;
    std::string stream;
    std::map<std::string, std::string> entries;  ///< the content's dictionary
    message msg;                                 ///< the stored post
};

/// SEARCH_SAMPLES criteria (OA-XSTREAM-9): inclusive time bounds in ms since the epoch,
/// parameter globs, at most the newest `latest` (0: all).
struct sample_search {
    std::optional<std::int64_t> after_ms;
    std::optional<std::int64_t> until_ms;
    std::vector<std::pair<std::string, std::string>> params;
    std::uint64_t latest = 0;
};

class stream;

/// A lock on a range of samples (LOCK_SAMPLES, OA-XSTREAM-5). RAII: the destructor releases it
/// (errors swallowed); `unlock()` releases it and reports errors. Move-only. It belongs to its
/// stream handle's connection and must not outlive the client.
class stream_lock {
public:
    stream_lock(stream_lock&& other) noexcept;
    stream_lock& operator=(stream_lock&& other) noexcept;
    stream_lock(const stream_lock&) = delete;
    stream_lock& operator=(const stream_lock&) = delete;
    ~stream_lock() noexcept;

    /// Release the lock (UNLOCK_SAMPLES); LOCK_UNKNOWN when the server no longer knows it.
    void unlock();
    /// Forget the lock without releasing it (it ends with the connection, or `stream::unlock`).
    std::uint64_t release() noexcept;
    [[nodiscard]] std::uint64_t id() const noexcept { return id_; }
    [[nodiscard]] std::uint64_t first() const noexcept { return first_; }
    [[nodiscard]] std::uint64_t last() const noexcept { return last_; }
    [[nodiscard]] bool held() const noexcept { return owner_ != nullptr; }

private:
    friend class stream;
    stream_lock(stream* owner, std::uint64_t id, std::uint64_t first, std::uint64_t last) noexcept
        : owner_(owner), id_(id), first_(first), last_(last) {}
    stream* owner_ = nullptr;
    std::uint64_t id_ = 0, first_ = 0, last_ = 0;
};

/// One stream, by name or (typed-streams) by type, as seen from a client. Get it with
/// `client::stream(target)`; it is owned by the client and valid while the client lives.
///
/// The handle talks to the stream over a connection of its own, opened on first use with
/// GET_NAME, so that the connection's current stream is always this one and `add_binary` can
/// send bare `BinaryM` frames (OA-STREAM-11). A failure reply throws an `openair::error` with
/// the condition it names (SAMPLE_UNKNOWN, SAMPLE_INVALID, STREAM_UNKNOWN, LOCK_UNKNOWN,
/// CONTENT_INVALID, COMMAND_UNKNOWN), else `request_failed`.
class stream {
public:
    stream(const stream&) = delete;
    stream& operator=(const stream&) = delete;

    /// The name or type the handle was made for.
    [[nodiscard]] const std::string& target() const noexcept;
    /// The stream's name (GET_NAME; a type resolved to the stream's name).
    [[nodiscard]] std::string name();

    /// Add one sample (ADD_SAMPLE) and return its id (OA-STREAM-5). The payload is copied once,
    /// into the frame being written.
    std::uint64_t add(bytes_view payload, const sample_options& options = {});
    /// Add one sample without waiting: `noreply="yes"` when the server advertises `noreply`
    /// (OA-MSG-15), else an ordinary ADD_SAMPLE whose reply is read and dropped (OA-GEN-2).
    void add_noreply(bytes_view payload, const sample_options& options = {});
    /// Add one sample as a bare `BinaryM` frame (OA-STREAM-11) and return its id.
    std::uint64_t add_binary(bytes_view payload, const sample_options& options = {});
    /// Add several samples in one ADD_SAMPLES (all or none, OA-STREAM-5); `options` is empty
    /// (none), one for all, or one per payload. Returns the ids in order.
    std::vector<std::uint64_t> add_many(const std::vector<bytes_view>& payloads,
                                        const std::vector<sample_options>& options = {});
    /// Add several samples, one ADD_SAMPLE (or `BinaryM` with `binary`) each, pipelined within
    /// the server's window (OA-SESS-17) before the replies are awaited; returns the ids.
    std::vector<std::uint64_t> add_pipelined(const std::vector<bytes_view>& payloads,
                                             const std::vector<sample_options>& options = {},
                                             bool binary = false);

    /// The sample with this id (SAMPLE_UNKNOWN when the stream does not hold it).
    [[nodiscard]] data_sample get(std::uint64_t id);
    /// The sample with the greatest timestamp at or before `ms` (ms since the epoch).
    [[nodiscard]] data_sample at(std::int64_t ms);
    /// The samples timestamped within [from_ms, until_ms], oldest first.
    [[nodiscard]] std::vector<data_sample> between(std::int64_t from_ms, std::int64_t until_ms);
    [[nodiscard]] data_sample newest();
    [[nodiscard]] data_sample oldest();
    [[nodiscard]] std::int64_t newest_timestamp();
    [[nodiscard]] std::int64_t oldest_timestamp();
    [[nodiscard]] std::uint64_t count();
    [[nodiscard]] std::uint64_t size();
    [[nodiscard]] stream_info info();
    /// SEARCH_SAMPLES (typed-streams; API_MISUSE when the server does not advertise it).
    [[nodiscard]] std::vector<data_sample> search(const sample_search& query);

    /// Wait up to `timeout` for a sample with an id greater than `id`: the oldest such (the
    /// newest with `last`); nullopt when the timeout passes first (OA-STREAM-7).
    [[nodiscard]] std::optional<data_sample> wait_after_id(std::uint64_t id,
                                                           std::chrono::milliseconds timeout,
                                                           bool last = false);
    /// Wait up to `timeout` for a sample timestamped at or after `ms`.
    [[nodiscard]] std::optional<data_sample> wait_sample(std::int64_t ms,
                                                         std::chrono::milliseconds timeout,
                                                         bool last = false);

    /// Lock the held samples with ids in [first, last] (typed-streams, OA-XSTREAM-5).
    [[nodiscard]] stream_lock lock(std::uint64_t first, std::uint64_t last);
    /// Release a lock this handle's connection holds (LOCK_UNKNOWN otherwise).
    void unlock(std::uint64_t lock_id);

private:
    friend class client;
    explicit stream(detail::stream_state* state) noexcept : state_(state) {}
    detail::stream_state* state_;
};

/// A push subscription to one stream (spec 11.6, OA-STREAM-8): a connection of its own on which
/// the server pushes every new sample as DATASAMPLE. Get it with `client::subscribe_stream`; it
/// is owned by the client and valid while the client lives.
///
/// Pull with `next(timeout)`, or set `on_sample` and let `client::poll` hand samples over. Each
/// sample is acknowledged once it is in the local buffer of `buffer` samples; a consumer that
/// falls behind holds the acknowledgements back, and the server then drops samples for this
/// subscriber only and says so in the next sample's `dropped`.
class stream_subscription {
public:
    stream_subscription(const stream_subscription&) = delete;
    stream_subscription& operator=(const stream_subscription&) = delete;

    /// The next sample, waiting up to `timeout` (servicing every connection meanwhile); nullopt
    /// on timeout. Throws CONNECTION_CLOSED once the push connection has ended and every sample
    /// received before was taken.
    [[nodiscard]] std::optional<received_sample> next(std::chrono::milliseconds timeout);
    /// Hand samples to `callback` from `client::poll` instead (on the caller's thread).
    void on_sample(std::function<void(const received_sample&)> callback);
    /// Close the push connection; samples already received stay available to `next`.
    void close() noexcept;
    /// True while the push connection is open.
    [[nodiscard]] bool active() const noexcept;
    [[nodiscard]] const std::string& target() const noexcept;
    /// How many samples arrived, and the sum of their `dropped` slots.
    [[nodiscard]] std::uint64_t received() const noexcept;
    [[nodiscard]] std::uint64_t dropped() const noexcept;

private:
    friend class client;
    explicit stream_subscription(detail::subscription_state* state) noexcept : state_(state) {}
    detail::subscription_state* state_;
};

/// Stream alarms as they are posted (OA-XSTREAM-6). A companion module `<name>-alarms-<n>`
/// registers a trigger on the alarm pattern, so the caller's own registration is untouched.
/// Get it with `client::alarms`; it owns its companion connection.
class alarm_subscription {
public:
    alarm_subscription(alarm_subscription&&) noexcept;
    alarm_subscription& operator=(alarm_subscription&&) noexcept;
    ~alarm_subscription() noexcept;

    /// The next alarm, waiting up to `timeout`; nullopt on timeout.
    [[nodiscard]] std::optional<stream_alarm> next(std::chrono::milliseconds timeout);
    void close() noexcept;

private:
    friend class client;
    struct state;
    explicit alarm_subscription(std::unique_ptr<state> s) noexcept;
    std::unique_ptr<state> state_;
};

}  // namespace openair
