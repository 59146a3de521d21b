// Internal: stream requests and replies as values, without I/O (spec section 11). The client's
// stream side (stream.cpp) builds its media commands here and reads the replies here; a reply
// that does not have the shape of spec 11.3-11.7 is CONTENT_INVALID (SAMPLE_INVALID for a bad
// chunk). Tested on its own in tests/test_sample_vectors.cpp.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "openair/datasample.hpp"
#include "openair/message.hpp"
#include "openair/stream.hpp"

namespace openair::detail {

inline constexpr const char* datasample_xml = "<datasample/>";

/// A media command to the stream `target` (its name or type) from `sender` (spec 11.1).
[[nodiscard]] message media_request(const std::string& target, const std::string& sender,
                                    const std::string& type, std::string content = "",
                                    bool xml = false);
/// ADD_SAMPLE (`<datasample/>`) or ADD_SAMPLES (`count` objects); the chunks are sent apart.
[[nodiscard]] message add_request(const std::string& target, const std::string& sender,
                                  std::size_t count);
/// The parameters of a sample to write: `options.params` in order, then `builtin:timestamp`
/// and `builtin:seq`, each replacing a parameter of its key in place (OA-STREAM-4).
[[nodiscard]] sample_params params_for(const sample_options& options);
/// The type of a waiting command: name, one space, the timeout in ms (spec 11.5).
[[nodiscard]] std::string wait_type(bool by_id, bool last, std::int64_t timeout_ms);
/// One `<time sec msec/>` element for a time in ms since the epoch.
[[nodiscard]] std::string time_content(std::int64_t ms);
/// GET_SAMPLES_BY_TIME content: an objectcollection of the two bounds.
[[nodiscard]] std::string range_content(std::int64_t from_ms, std::int64_t until_ms);
/// SEARCH_SAMPLES content `<samplesearch>` (OA-XSTREAM-9); times as ms text.
[[nodiscard]] std::string search_content(const sample_search& query);

/// Throw the error a failure reply names (OA-ERR-2): the condition of `NAME: detail`, or
/// COMMAND_UNKNOWN for UNKNOWN_COMMAND, else `request_failed`.
[[noreturn]] void raise_for(const message& sent, const message& reply);
/// `reply` when its type is `type`, else `raise_for`.
const message& expect_reply(const message& sent, const message& reply, const char* type);

/// A decimal text reply (DATA_ACCEPTED id, COUNT, SIZE, LOCKED); CONTENT_INVALID otherwise.
[[nodiscard]] std::uint64_t integer_of(const message& reply, const char* what);
/// ADD_SAMPLES's `<collection><entry>id</entry>…</collection>`.
[[nodiscard]] std::vector<std::uint64_t> ids_of(const std::string& content);
/// A TIMESTAMP reply (one time element) in ms since the epoch.
[[nodiscard]] std::int64_t timestamp_of(const message& reply);
/// One `<streaminfo>` element as content.
[[nodiscard]] stream_info stream_info_of(const std::string& content);
/// A STREAMS reply's `<streams>` of `<streaminfo>` (OA-STREAM-16); empty content: none.
[[nodiscard]] std::vector<stream_info> stream_list_of(const std::string& content);
/// The one sample of a DATASAMPLE message; its chunk is moved out of `msg`.
[[nodiscard]] data_sample sample_of(message msg);
/// The samples of a DATASAMPLES reply: one chunk per `<datasample>` element, oldest first.
[[nodiscard]] std::vector<data_sample> samples_of(message msg);
/// A pushed DATASAMPLE, its `dropped` slot included (OA-STREAM-8).
[[nodiscard]] received_sample received_sample_of(message msg, std::int64_t received_ns);
/// Whether `msg` is an `AIR.Stream.Alarm.<Kind>` post, and the alarm it is.
[[nodiscard]] bool is_alarm(const message& msg);
[[nodiscard]] stream_alarm alarm_of(const message& msg);

}  // namespace openair::detail
