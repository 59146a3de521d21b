// generated from spec/errors.xml by tools/gen_errors.py — do not edit
#pragma once

#include <optional>
#include <string_view>

namespace openair {

/// The stable codes of the OpenAIR error table (spec section 13, spec/errors.xml).
enum class errc : int {
    /// The frame header carries a tag other than Message, Receive or BinaryM, or the byte after the tag is not NUL.
    frame_unknown_tag = 100,
    /// The announced XML length exceeds the receiver's limit.
    frame_too_large = 101,
    /// The connection ended, or the read deadline passed, inside a frame.
    frame_truncated = 102,
    /// The binary chunks announced by binarysizes exceed the receiver's limit.
    binary_too_large = 103,
    /// The binarysizes slot is not a comma-separated list of non-negative decimal integers, or disagrees with totalbinarysize.
    binary_sizes_invalid = 104,
    /// The frame's XML is not well-formed, is not UTF-8, or its root is not message.
    xml_malformed = 200,
    /// The XML contains a DOCTYPE, an entity declaration or an external reference.
    xml_forbidden = 201,
    /// The XML nests elements deeper than the receiver's limit.
    xml_too_deep = 202,
    /// A slot has an invalid value (for example a missing type, a non-numeric priority or time).
    message_invalid = 203,
    /// A posted type is not a valid type (empty segment, whitespace, or a '*').
    type_invalid = 204,
    /// The content of a control message is not the object its type requires.
    content_invalid = 205,
    /// The addressee does not know the command type.
    command_unknown = 300,
    /// The to slot names no whiteboard, component or bound module.
    forward_failed = 301,
    /// RESOLVE_REQUEST names nothing the server knows.
    name_unresolved = 302,
    /// The module name in BIND is not a valid name, or the requested port cannot be honoured.
    bind_refused = 303,
    /// A registration or retrieve names a whiteboard that does not exist.
    whiteboard_unknown = 304,
    /// An AUTH_RESPONSE proof does not verify: no challenge is pending on the connection, the name has no secret, or the HMAC is wrong (extension auth).
    auth_failed = 305,
    /// In secure mode the connection has not proved the name the request acts for, or the request posts a type only the server sends (extension auth).
    auth_required = 306,
    /// The AIR.Subscribe content is none of the registration forms, or a trigger lacks a type.
    registration_invalid = 400,
    /// A trigger or retrieve pattern is not a valid pattern (for example two consecutive '*').
    pattern_invalid = 401,
    /// The retrieve specification is empty, unparsable, or has an invalid criterion.
    retrieve_invalid = 402,
    /// A receiving module's queue was full and messages were dropped for it.
    queue_overflow = 500,
    /// A wakeup could not be delivered after the retries the spec allows.
    delivery_failed = 501,
    /// A request exceeds a limit other than the frame limits (pipelined requests in flight, triggers per registration, retrieve results).
    limit_exceeded = 502,
    /// The whiteboard could not store the message; it was not accepted.
    store_failed = 503,
    /// The server is shutting down and accepts no new work.
    shutting_down = 504,
    /// The stream named by a media command, or by the to of a push subscription, does not exist.
    stream_unknown = 600,
    /// No sample matches the id or time asked for, or none arrived before a wait timed out.
    sample_unknown = 601,
    /// A sample is malformed, does not match the chunks of its request, or its payload alone exceeds the stream's byte limit.
    sample_invalid = 602,
    /// UNLOCK_SAMPLES names a lock id that the stream never gave out, that is already released, or that another connection holds.
    lock_unknown = 603,
    /// The API was used in a way the protocol does not allow (for example sending in a closed state).
    api_misuse = 900,
    /// The connection is closed; the operation cannot complete.
    connection_closed = 901,
    /// No reply arrived within the caller's deadline.
    request_timeout = 902,
    /// The peer answered a request with a failure reply (its type and content are kept).
    request_failed = 903,
};

/// Who is at fault for a condition (OA-GEN-3).
enum class blame { remote, peer, local };

/// The condition name that travels on the wire (RECEIVE_ERROR content `NAME: detail`).
constexpr std::string_view errc_name(errc e) noexcept {
    switch (e) {
        case errc::frame_unknown_tag: return "FRAME_UNKNOWN_TAG";
        case errc::frame_too_large: return "FRAME_TOO_LARGE";
        case errc::frame_truncated: return "FRAME_TRUNCATED";
        case errc::binary_too_large: return "BINARY_TOO_LARGE";
        case errc::binary_sizes_invalid: return "BINARY_SIZES_INVALID";
        case errc::xml_malformed: return "XML_MALFORMED";
        case errc::xml_forbidden: return "XML_FORBIDDEN";
        case errc::xml_too_deep: return "XML_TOO_DEEP";
        case errc::message_invalid: return "MESSAGE_INVALID";
        case errc::type_invalid: return "TYPE_INVALID";
        case errc::content_invalid: return "CONTENT_INVALID";
        case errc::command_unknown: return "COMMAND_UNKNOWN";
        case errc::forward_failed: return "FORWARD_FAILED";
        case errc::name_unresolved: return "NAME_UNRESOLVED";
        case errc::bind_refused: return "BIND_REFUSED";
        case errc::whiteboard_unknown: return "WHITEBOARD_UNKNOWN";
        case errc::auth_failed: return "AUTH_FAILED";
        case errc::auth_required: return "AUTH_REQUIRED";
        case errc::registration_invalid: return "REGISTRATION_INVALID";
        case errc::pattern_invalid: return "PATTERN_INVALID";
        case errc::retrieve_invalid: return "RETRIEVE_INVALID";
        case errc::queue_overflow: return "QUEUE_OVERFLOW";
        case errc::delivery_failed: return "DELIVERY_FAILED";
        case errc::limit_exceeded: return "LIMIT_EXCEEDED";
        case errc::store_failed: return "STORE_FAILED";
        case errc::shutting_down: return "SHUTTING_DOWN";
        case errc::stream_unknown: return "STREAM_UNKNOWN";
        case errc::sample_unknown: return "SAMPLE_UNKNOWN";
        case errc::sample_invalid: return "SAMPLE_INVALID";
        case errc::lock_unknown: return "LOCK_UNKNOWN";
        case errc::api_misuse: return "API_MISUSE";
        case errc::connection_closed: return "CONNECTION_CLOSED";
        case errc::request_timeout: return "REQUEST_TIMEOUT";
        case errc::request_failed: return "REQUEST_FAILED";
    }
    return "UNKNOWN";
}

/// Who is at fault for the condition.
constexpr blame errc_blame(errc e) noexcept {
    switch (e) {
        case errc::frame_unknown_tag: return blame::remote;
        case errc::frame_too_large: return blame::remote;
        case errc::frame_truncated: return blame::remote;
        case errc::binary_too_large: return blame::remote;
        case errc::binary_sizes_invalid: return blame::remote;
        case errc::xml_malformed: return blame::remote;
        case errc::xml_forbidden: return blame::remote;
        case errc::xml_too_deep: return blame::remote;
        case errc::message_invalid: return blame::remote;
        case errc::type_invalid: return blame::remote;
        case errc::content_invalid: return blame::remote;
        case errc::command_unknown: return blame::remote;
        case errc::forward_failed: return blame::peer;
        case errc::name_unresolved: return blame::peer;
        case errc::bind_refused: return blame::peer;
        case errc::whiteboard_unknown: return blame::peer;
        case errc::auth_failed: return blame::remote;
        case errc::auth_required: return blame::peer;
        case errc::registration_invalid: return blame::remote;
        case errc::pattern_invalid: return blame::remote;
        case errc::retrieve_invalid: return blame::remote;
        case errc::queue_overflow: return blame::peer;
        case errc::delivery_failed: return blame::peer;
        case errc::limit_exceeded: return blame::remote;
        case errc::store_failed: return blame::peer;
        case errc::shutting_down: return blame::peer;
        case errc::stream_unknown: return blame::peer;
        case errc::sample_unknown: return blame::peer;
        case errc::sample_invalid: return blame::remote;
        case errc::lock_unknown: return blame::peer;
        case errc::api_misuse: return blame::local;
        case errc::connection_closed: return blame::local;
        case errc::request_timeout: return blame::local;
        case errc::request_failed: return blame::peer;
    }
    return blame::remote;
}

/// Whether the condition blames the local caller (API misuse and local conditions).
constexpr bool errc_is_local(errc e) noexcept { return errc_blame(e) == blame::local; }

/// Whether the connection that carried the condition is closed afterwards.
constexpr bool errc_closes(errc e) noexcept {
    switch (e) {
        case errc::frame_unknown_tag: return true;
        case errc::frame_too_large: return true;
        case errc::frame_truncated: return true;
        case errc::binary_too_large: return true;
        case errc::binary_sizes_invalid: return true;
        case errc::xml_malformed: return false;
        case errc::xml_forbidden: return false;
        case errc::xml_too_deep: return false;
        case errc::message_invalid: return false;
        case errc::type_invalid: return false;
        case errc::content_invalid: return false;
        case errc::command_unknown: return false;
        case errc::forward_failed: return false;
        case errc::name_unresolved: return false;
        case errc::bind_refused: return false;
        case errc::whiteboard_unknown: return false;
        case errc::auth_failed: return false;
        case errc::auth_required: return false;
        case errc::registration_invalid: return false;
        case errc::pattern_invalid: return false;
        case errc::retrieve_invalid: return false;
        case errc::queue_overflow: return false;
        case errc::delivery_failed: return false;
        case errc::limit_exceeded: return false;
        case errc::store_failed: return false;
        case errc::shutting_down: return true;
        case errc::stream_unknown: return false;
        case errc::sample_unknown: return false;
        case errc::sample_invalid: return false;
        case errc::lock_unknown: return false;
        case errc::api_misuse: return false;
        case errc::connection_closed: return false;
        case errc::request_timeout: return false;
        case errc::request_failed: return false;
    }
    return false;
}

/// The reply a server sends for the condition ("" when none is sent).
constexpr std::string_view errc_reply(errc e) noexcept {
    switch (e) {
        case errc::frame_unknown_tag: return "";
        case errc::frame_too_large: return "RECEIVE_ERROR";
        case errc::frame_truncated: return "";
        case errc::binary_too_large: return "RECEIVE_ERROR";
        case errc::binary_sizes_invalid: return "RECEIVE_ERROR";
        case errc::xml_malformed: return "RECEIVE_ERROR";
        case errc::xml_forbidden: return "RECEIVE_ERROR";
        case errc::xml_too_deep: return "RECEIVE_ERROR";
        case errc::message_invalid: return "RECEIVE_ERROR";
        case errc::type_invalid: return "RECEIVE_ERROR";
        case errc::content_invalid: return "RECEIVE_ERROR";
        case errc::command_unknown: return "UNKNOWN_COMMAND";
        case errc::forward_failed: return "FORWARD_FAILED";
        case errc::name_unresolved: return "RESOLVE_FAILED";
        case errc::bind_refused: return "BIND_ERROR";
        case errc::whiteboard_unknown: return "RECEIVE_ERROR";
        case errc::auth_failed: return "RECEIVE_ERROR";
        case errc::auth_required: return "RECEIVE_ERROR";
        case errc::registration_invalid: return "RECEIVE_ERROR";
        case errc::pattern_invalid: return "RECEIVE_ERROR";
        case errc::retrieve_invalid: return "AIR.Retrieve.Failed";
        case errc::queue_overflow: return "";
        case errc::delivery_failed: return "";
        case errc::limit_exceeded: return "RECEIVE_ERROR";
        case errc::store_failed: return "RECEIVE_ERROR";
        case errc::shutting_down: return "RECEIVE_ERROR";
        case errc::stream_unknown: return "RECEIVE_ERROR";
        case errc::sample_unknown: return "RECEIVE_ERROR";
        case errc::sample_invalid: return "DATA_NOT_ACCEPTED";
        case errc::lock_unknown: return "RECEIVE_ERROR";
        case errc::api_misuse: return "";
        case errc::connection_closed: return "";
        case errc::request_timeout: return "";
        case errc::request_failed: return "";
    }
    return "";
}

/// The table's one-line description of the condition.
constexpr std::string_view errc_text(errc e) noexcept {
    switch (e) {
        case errc::frame_unknown_tag: return "The frame header carries a tag other than Message, Receive or BinaryM, or the byte after the tag is not NUL.";
        case errc::frame_too_large: return "The announced XML length exceeds the receiver's limit.";
        case errc::frame_truncated: return "The connection ended, or the read deadline passed, inside a frame.";
        case errc::binary_too_large: return "The binary chunks announced by binarysizes exceed the receiver's limit.";
        case errc::binary_sizes_invalid: return "The binarysizes slot is not a comma-separated list of non-negative decimal integers, or disagrees with totalbinarysize.";
        case errc::xml_malformed: return "The frame's XML is not well-formed, is not UTF-8, or its root is not message.";
        case errc::xml_forbidden: return "The XML contains a DOCTYPE, an entity declaration or an external reference.";
        case errc::xml_too_deep: return "The XML nests elements deeper than the receiver's limit.";
        case errc::message_invalid: return "A slot has an invalid value (for example a missing type, a non-numeric priority or time).";
        case errc::type_invalid: return "A posted type is not a valid type (empty segment, whitespace, or a '*').";
        case errc::content_invalid: return "The content of a control message is not the object its type requires.";
        case errc::command_unknown: return "The addressee does not know the command type.";
        case errc::forward_failed: return "The to slot names no whiteboard, component or bound module.";
        case errc::name_unresolved: return "RESOLVE_REQUEST names nothing the server knows.";
        case errc::bind_refused: return "The module name in BIND is not a valid name, or the requested port cannot be honoured.";
        case errc::whiteboard_unknown: return "A registration or retrieve names a whiteboard that does not exist.";
        case errc::auth_failed: return "An AUTH_RESPONSE proof does not verify: no challenge is pending on the connection, the name has no secret, or the HMAC is wrong (extension auth).";
        case errc::auth_required: return "In secure mode the connection has not proved the name the request acts for, or the request posts a type only the server sends (extension auth).";
        case errc::registration_invalid: return "The AIR.Subscribe content is none of the registration forms, or a trigger lacks a type.";
        case errc::pattern_invalid: return "A trigger or retrieve pattern is not a valid pattern (for example two consecutive '*').";
        case errc::retrieve_invalid: return "The retrieve specification is empty, unparsable, or has an invalid criterion.";
        case errc::queue_overflow: return "A receiving module's queue was full and messages were dropped for it.";
        case errc::delivery_failed: return "A wakeup could not be delivered after the retries the spec allows.";
        case errc::limit_exceeded: return "A request exceeds a limit other than the frame limits (pipelined requests in flight, triggers per registration, retrieve results).";
        case errc::store_failed: return "The whiteboard could not store the message; it was not accepted.";
        case errc::shutting_down: return "The server is shutting down and accepts no new work.";
        case errc::stream_unknown: return "The stream named by a media command, or by the to of a push subscription, does not exist.";
        case errc::sample_unknown: return "No sample matches the id or time asked for, or none arrived before a wait timed out.";
        case errc::sample_invalid: return "A sample is malformed, does not match the chunks of its request, or its payload alone exceeds the stream's byte limit.";
        case errc::lock_unknown: return "UNLOCK_SAMPLES names a lock id that the stream never gave out, that is already released, or that another connection holds.";
        case errc::api_misuse: return "The API was used in a way the protocol does not allow (for example sending in a closed state).";
        case errc::connection_closed: return "The connection is closed; the operation cannot complete.";
        case errc::request_timeout: return "No reply arrived within the caller's deadline.";
        case errc::request_failed: return "The peer answered a request with a failure reply (its type and content are kept).";
    }
    return "";
}

/// Look a condition up by its wire name; nullopt when the table has no such name.
constexpr std::optional<errc> errc_from_name(std::string_view name) noexcept {
    if (name == "FRAME_UNKNOWN_TAG") return errc::frame_unknown_tag;
    if (name == "FRAME_TOO_LARGE") return errc::frame_too_large;
    if (name == "FRAME_TRUNCATED") return errc::frame_truncated;
    if (name == "BINARY_TOO_LARGE") return errc::binary_too_large;
    if (name == "BINARY_SIZES_INVALID") return errc::binary_sizes_invalid;
    if (name == "XML_MALFORMED") return errc::xml_malformed;
    if (name == "XML_FORBIDDEN") return errc::xml_forbidden;
    if (name == "XML_TOO_DEEP") return errc::xml_too_deep;
    if (name == "MESSAGE_INVALID") return errc::message_invalid;
    if (name == "TYPE_INVALID") return errc::type_invalid;
    if (name == "CONTENT_INVALID") return errc::content_invalid;
    if (name == "COMMAND_UNKNOWN") return errc::command_unknown;
    if (name == "FORWARD_FAILED") return errc::forward_failed;
    if (name == "NAME_UNRESOLVED") return errc::name_unresolved;
    if (name == "BIND_REFUSED") return errc::bind_refused;
    if (name == "WHITEBOARD_UNKNOWN") return errc::whiteboard_unknown;
    if (name == "AUTH_FAILED") return errc::auth_failed;
    if (name == "AUTH_REQUIRED") return errc::auth_required;
    if (name == "REGISTRATION_INVALID") return errc::registration_invalid;
    if (name == "PATTERN_INVALID") return errc::pattern_invalid;
    if (name == "RETRIEVE_INVALID") return errc::retrieve_invalid;
    if (name == "QUEUE_OVERFLOW") return errc::queue_overflow;
    if (name == "DELIVERY_FAILED") return errc::delivery_failed;
    if (name == "LIMIT_EXCEEDED") return errc::limit_exceeded;
    if (name == "STORE_FAILED") return errc::store_failed;
    if (name == "SHUTTING_DOWN") return errc::shutting_down;
    if (name == "STREAM_UNKNOWN") return errc::stream_unknown;
    if (name == "SAMPLE_UNKNOWN") return errc::sample_unknown;
    if (name == "SAMPLE_INVALID") return errc::sample_invalid;
    if (name == "LOCK_UNKNOWN") return errc::lock_unknown;
    if (name == "API_MISUSE") return errc::api_misuse;
    if (name == "CONNECTION_CLOSED") return errc::connection_closed;
    if (name == "REQUEST_TIMEOUT") return errc::request_timeout;
    if (name == "REQUEST_FAILED") return errc::request_failed;
    return std::nullopt;
}

}  // namespace openair
