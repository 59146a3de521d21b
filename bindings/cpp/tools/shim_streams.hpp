// The stream commands of the shim driver (PROTOCOL.md, "Streams and attachments"), and the
// base64 the protocol carries bytes in. Not part of the client library.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "openair/client.hpp"
#include "shim.hpp"

namespace openair::shim {

/// Standard base64 with padding, and back (API_MISUSE for text that is not base64).
[[nodiscard]] std::string base64_encode(bytes_view bytes);
[[nodiscard]] std::string base64_decode(std::string_view text);

/// A message's binary chunks as the protocol's `attachments` (base64, in order).
[[nodiscard]] json attachments_json(const openair::message& m);

/// The optional stream commands; `run` answers false for a command it does not know.
class stream_commands {
public:
    /// Route the client's registration samples here (call once after connecting).
    void attach(openair::client& c);
    /// Run `name` when it is a stream command; false when it is not one.
    bool run(openair::client& c, const std::string& name, const json& cmd, json& out);

private:
    openair::stream_subscription& subscription(const json& cmd);
    json add(openair::client& c, const json& cmd);
    json add_many(openair::client& c, const json& cmd);
    json read(openair::client& c, const json& cmd);
    json wait(openair::client& c, const json& cmd);

    std::map<std::int64_t, openair::stream_subscription*> subscriptions_;
    std::map<std::int64_t, openair::alarm_subscription> alarms_;
    std::int64_t next_handle_ = 1;
    std::shared_ptr<std::deque<openair::received_sample>> samples_ =
        std::make_shared<std::deque<openair::received_sample>>();
};

}  // namespace openair::shim
