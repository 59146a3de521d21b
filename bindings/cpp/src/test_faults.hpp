// Internal: fault injection for the deliberately broken conformance shim (openair-shim-broken).
//
// The client-conformance tests (tests/bindings) prove that `openair conform-client` catches a
// C++ library that misbehaves. Behaviours that live in the library, not in the shim, are broken
// through these hooks. They exist only when OPENAIR_TEST_FAULTS is defined, which only the
// test library `openair_client_faults` does: in the real library every OPENAIR_FAULT(...) is the
// constant `false`, so no fault state, name or branch is compiled into it.
#pragma once

#ifdef OPENAIR_TEST_FAULTS

#include <string_view>
#include <vector>

namespace openair::detail::faults {

/// One broken behaviour of the library; at most one is active in a process.
enum class fault {
    none,
    lowercase_postedtime,  ///< write the legacy spelling `postedtime` (codec)
    no_posted_time,        ///< send every message without postedTime (session)
    no_ack,                ///< compute the acknowledgement of a wakeup, then never send it
    wrong_isresponse,      ///< acknowledge wakeups with an isresponse that names no request
    ping_accept,           ///< answer PING with RECEIVE_ACCEPT
    no_callback,           ///< never open the callback connection (connect still succeeds)
    noreply_to_legacy,     ///< send noreply="yes" whatever the server advertised
    pipelining_to_legacy,  ///< keep several requests in flight whatever the server advertised
    crash_on_malformed,    ///< exit the process when a delivery cannot be read
    accept_malformed,      ///< answer a delivery that cannot be read with RECEIVE_ACCEPT
    // streams (client_streams.cpp, stream_wire.cpp, client_io.cpp)
    push_no_ack,                ///< never acknowledge a pushed DATASAMPLE
    wait_timeout_error,         ///< report a wait that timed out as SAMPLE_UNKNOWN, not "none"
    push_end_silent,            ///< report the end of a push connection as a timeout
    builtins_first,             ///< write builtin:timestamp/seq before the writer's parameters
    registration_samples_lost,  ///< acknowledge a registration's samples, never report them
    attachments_dropped,        ///< read nested copies' chunks, never give them to the copies
};

/// The active fault (`none` until `select` is called).
[[nodiscard]] fault active() noexcept;
/// Activate the fault called `name` (the enumerator with '-' for '_'); false if unknown.
bool select(std::string_view name) noexcept;
/// The names `select` accepts.
[[nodiscard]] std::vector<std::string_view> names();

}  // namespace openair::detail::faults

#define OPENAIR_FAULT(name)                    \
    (::openair::detail::faults::active() ==    \
     ::openair::detail::faults::fault::name)

#else

#define OPENAIR_FAULT(name) false

#endif
