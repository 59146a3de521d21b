"""OpenAIR error conditions.

Generated from spec/errors.xml by tools/gen_errors.py — do not edit.
"""

from __future__ import annotations

import enum

from openair.protocol._errors_base import (
    Blame,
    LocalProtocolError,
    OpenAIRError,
    PeerError,
    RemoteProtocolError,
)


class ErrorCode(enum.IntEnum):
    """Stable numeric codes of the error table."""

    FRAME_UNKNOWN_TAG = 100
    FRAME_TOO_LARGE = 101
    FRAME_TRUNCATED = 102
    BINARY_TOO_LARGE = 103
    BINARY_SIZES_INVALID = 104
    XML_MALFORMED = 200
    XML_FORBIDDEN = 201
    XML_TOO_DEEP = 202
    MESSAGE_INVALID = 203
    TYPE_INVALID = 204
    CONTENT_INVALID = 205
    COMMAND_UNKNOWN = 300
    FORWARD_FAILED = 301
    NAME_UNRESOLVED = 302
    BIND_REFUSED = 303
    WHITEBOARD_UNKNOWN = 304
    AUTH_FAILED = 305
    AUTH_REQUIRED = 306
    REGISTRATION_INVALID = 400
    PATTERN_INVALID = 401
    RETRIEVE_INVALID = 402
    QUEUE_OVERFLOW = 500
    DELIVERY_FAILED = 501
    LIMIT_EXCEEDED = 502
    STORE_FAILED = 503
    SHUTTING_DOWN = 504
    STREAM_UNKNOWN = 600
    SAMPLE_UNKNOWN = 601
    SAMPLE_INVALID = 602
    LOCK_UNKNOWN = 603
    API_MISUSE = 900
    CONNECTION_CLOSED = 901
    REQUEST_TIMEOUT = 902
    REQUEST_FAILED = 903


class FrameUnknownTagError(RemoteProtocolError):
    """The frame header carries a tag other than Message, Receive or BinaryM, or the byte after the
    tag is not NUL.
    """

    code = ErrorCode.FRAME_UNKNOWN_TAG
    name = "FRAME_UNKNOWN_TAG"
    blame = Blame.REMOTE
    reply = None
    closes = True
    requirements = ("OA-FRAME-6",)


class FrameTooLargeError(RemoteProtocolError):
    """The announced XML length exceeds the receiver's limit."""

    code = ErrorCode.FRAME_TOO_LARGE
    name = "FRAME_TOO_LARGE"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = True
    requirements = ("OA-FRAME-7", "OA-LIM-1")


class FrameTruncatedError(RemoteProtocolError):
    """The connection ended, or the read deadline passed, inside a frame."""

    code = ErrorCode.FRAME_TRUNCATED
    name = "FRAME_TRUNCATED"
    blame = Blame.REMOTE
    reply = None
    closes = True
    requirements = ("OA-FRAME-8",)


class BinaryTooLargeError(RemoteProtocolError):
    """The binary chunks announced by binarysizes exceed the receiver's limit."""

    code = ErrorCode.BINARY_TOO_LARGE
    name = "BINARY_TOO_LARGE"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = True
    requirements = ("OA-FRAME-7", "OA-LIM-2")


class BinarySizesInvalidError(RemoteProtocolError):
    """The binarysizes slot is not a comma-separated list of non-negative decimal integers, or
    disagrees with totalbinarysize.
    """

    code = ErrorCode.BINARY_SIZES_INVALID
    name = "BINARY_SIZES_INVALID"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = True
    requirements = ("OA-FRAME-4",)


class XmlMalformedError(RemoteProtocolError):
    """The frame's XML is not well-formed, is not UTF-8, or its root is not message."""

    code = ErrorCode.XML_MALFORMED
    name = "XML_MALFORMED"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-MSG-1", "OA-ERR-3")


class XmlForbiddenError(RemoteProtocolError):
    """The XML contains a DOCTYPE, an entity declaration or an external reference."""

    code = ErrorCode.XML_FORBIDDEN
    name = "XML_FORBIDDEN"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-SEC-1", "OA-SEC-2")


class XmlTooDeepError(RemoteProtocolError):
    """The XML nests elements deeper than the receiver's limit."""

    code = ErrorCode.XML_TOO_DEEP
    name = "XML_TOO_DEEP"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-LIM-3",)


class MessageInvalidError(RemoteProtocolError):
    """A slot has an invalid value (for example a missing type, a non-numeric priority or time)."""

    code = ErrorCode.MESSAGE_INVALID
    name = "MESSAGE_INVALID"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-MSG-2", "OA-MSG-9")


class TypeInvalidError(RemoteProtocolError):
    """A posted type is not a valid type (empty segment, whitespace, or a '*')."""

    code = ErrorCode.TYPE_INVALID
    name = "TYPE_INVALID"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-TYPE-1", "OA-TYPE-3")


class ContentInvalidError(RemoteProtocolError):
    """The content of a control message is not the object its type requires."""

    code = ErrorCode.CONTENT_INVALID
    name = "CONTENT_INVALID"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-MSG-12",)


class CommandUnknownError(RemoteProtocolError):
    """The addressee does not know the command type."""

    code = ErrorCode.COMMAND_UNKNOWN
    name = "COMMAND_UNKNOWN"
    blame = Blame.REMOTE
    reply = "UNKNOWN_COMMAND"
    closes = False
    requirements = ("OA-SESS-20",)


class ForwardFailedError(PeerError):
    """The to slot names no whiteboard, component or bound module."""

    code = ErrorCode.FORWARD_FAILED
    name = "FORWARD_FAILED"
    blame = Blame.PEER
    reply = "FORWARD_FAILED"
    closes = False
    requirements = ("OA-SESS-21",)


class NameUnresolvedError(PeerError):
    """RESOLVE_REQUEST names nothing the server knows."""

    code = ErrorCode.NAME_UNRESOLVED
    name = "NAME_UNRESOLVED"
    blame = Blame.PEER
    reply = "RESOLVE_FAILED"
    closes = False
    requirements = ("OA-SESS-8",)


class BindRefusedError(PeerError):
    """The module name in BIND is not a valid name, or the requested port cannot be honoured."""

    code = ErrorCode.BIND_REFUSED
    name = "BIND_REFUSED"
    blame = Blame.PEER
    reply = "BIND_ERROR"
    closes = False
    requirements = ("OA-SESS-4",)


class WhiteboardUnknownError(PeerError):
    """A registration or retrieve names a whiteboard that does not exist."""

    code = ErrorCode.WHITEBOARD_UNKNOWN
    name = "WHITEBOARD_UNKNOWN"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-RET-11", "OA-REG-9")


class AuthFailedError(RemoteProtocolError):
    """An AUTH_RESPONSE proof does not verify: no challenge is pending on the connection, the name
    has no secret, or the HMAC is wrong (extension auth).
    """

    code = ErrorCode.AUTH_FAILED
    name = "AUTH_FAILED"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-AUTH-3",)


class AuthRequiredError(PeerError):
    """In secure mode the connection has not proved the name the request acts for, or the request
    posts a type only the server sends (extension auth).
    """

    code = ErrorCode.AUTH_REQUIRED
    name = "AUTH_REQUIRED"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-AUTH-5", "OA-AUTH-6", "OA-AUTH-8")


class RegistrationInvalidError(RemoteProtocolError):
    """The AIR.Subscribe content is none of the registration forms, or a trigger lacks a type."""

    code = ErrorCode.REGISTRATION_INVALID
    name = "REGISTRATION_INVALID"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-REG-8",)


class PatternInvalidError(RemoteProtocolError):
    """A trigger or retrieve pattern is not a valid pattern (for example two consecutive '*')."""

    code = ErrorCode.PATTERN_INVALID
    name = "PATTERN_INVALID"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-MATCH-7",)


class RetrieveInvalidError(RemoteProtocolError):
    """The retrieve specification is empty, unparsable, or has an invalid criterion."""

    code = ErrorCode.RETRIEVE_INVALID
    name = "RETRIEVE_INVALID"
    blame = Blame.REMOTE
    reply = "AIR.Retrieve.Failed"
    closes = False
    requirements = ("OA-RET-10",)


class QueueOverflowError(PeerError):
    """A receiving module's queue was full and messages were dropped for it."""

    code = ErrorCode.QUEUE_OVERFLOW
    name = "QUEUE_OVERFLOW"
    blame = Blame.PEER
    reply = None
    closes = False
    requirements = ("OA-DELIV-9",)


class DeliveryFailedError(PeerError):
    """A wakeup could not be delivered after the retries the spec allows."""

    code = ErrorCode.DELIVERY_FAILED
    name = "DELIVERY_FAILED"
    blame = Blame.PEER
    reply = None
    closes = False
    requirements = ("OA-DELIV-7",)


class LimitExceededError(RemoteProtocolError):
    """A request exceeds a limit other than the frame limits (pipelined requests in flight,
    triggers per registration, retrieve results).
    """

    code = ErrorCode.LIMIT_EXCEEDED
    name = "LIMIT_EXCEEDED"
    blame = Blame.REMOTE
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-LIM-5",)


class StoreFailedError(PeerError):
    """The whiteboard could not store the message; it was not accepted."""

    code = ErrorCode.STORE_FAILED
    name = "STORE_FAILED"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-WB-3",)


class ShuttingDownError(PeerError):
    """The server is shutting down and accepts no new work."""

    code = ErrorCode.SHUTTING_DOWN
    name = "SHUTTING_DOWN"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = True
    requirements = ("OA-SESS-24",)


class StreamUnknownError(PeerError):
    """The stream named by a media command, or by the to of a push subscription, does not exist."""

    code = ErrorCode.STREAM_UNKNOWN
    name = "STREAM_UNKNOWN"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-STREAM-3", "OA-STREAM-8")


class SampleUnknownError(PeerError):
    """No sample matches the id or time asked for, or none arrived before a wait timed out."""

    code = ErrorCode.SAMPLE_UNKNOWN
    name = "SAMPLE_UNKNOWN"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-STREAM-6", "OA-STREAM-7")


class SampleInvalidError(RemoteProtocolError):
    """A sample is malformed, does not match the chunks of its request, or its payload alone
    exceeds the stream's byte limit.
    """

    code = ErrorCode.SAMPLE_INVALID
    name = "SAMPLE_INVALID"
    blame = Blame.REMOTE
    reply = "DATA_NOT_ACCEPTED"
    closes = False
    requirements = ("OA-STREAM-5", "OA-STREAM-10", "OA-STREAM-13")


class LockUnknownError(PeerError):
    """UNLOCK_SAMPLES names a lock id that the stream never gave out, that is already released, or
    that another connection holds.
    """

    code = ErrorCode.LOCK_UNKNOWN
    name = "LOCK_UNKNOWN"
    blame = Blame.PEER
    reply = "RECEIVE_ERROR"
    closes = False
    requirements = ("OA-XSTREAM-5",)


class ApiMisuseError(LocalProtocolError):
    """The API was used in a way the protocol does not allow (for example sending in a closed
    state).
    """

    code = ErrorCode.API_MISUSE
    name = "API_MISUSE"
    blame = Blame.LOCAL
    reply = None
    closes = False
    requirements = ("OA-GEN-3",)


class ConnectionClosedError(LocalProtocolError):
    """The connection is closed; the operation cannot complete."""

    code = ErrorCode.CONNECTION_CLOSED
    name = "CONNECTION_CLOSED"
    blame = Blame.LOCAL
    reply = None
    closes = False
    requirements = ("OA-GEN-3",)


class RequestTimeoutError(LocalProtocolError):
    """No reply arrived within the caller's deadline."""

    code = ErrorCode.REQUEST_TIMEOUT
    name = "REQUEST_TIMEOUT"
    blame = Blame.LOCAL
    reply = None
    closes = False
    requirements = ("OA-GEN-3",)


class RequestFailedError(PeerError):
    """The peer answered a request with a failure reply (its type and content are kept)."""

    code = ErrorCode.REQUEST_FAILED
    name = "REQUEST_FAILED"
    blame = Blame.PEER
    reply = None
    closes = False
    requirements = ("OA-GEN-3",)


ERRORS: dict[str, type[OpenAIRError]] = {
    "FRAME_UNKNOWN_TAG": FrameUnknownTagError,
    "FRAME_TOO_LARGE": FrameTooLargeError,
    "FRAME_TRUNCATED": FrameTruncatedError,
    "BINARY_TOO_LARGE": BinaryTooLargeError,
    "BINARY_SIZES_INVALID": BinarySizesInvalidError,
    "XML_MALFORMED": XmlMalformedError,
    "XML_FORBIDDEN": XmlForbiddenError,
    "XML_TOO_DEEP": XmlTooDeepError,
    "MESSAGE_INVALID": MessageInvalidError,
    "TYPE_INVALID": TypeInvalidError,
    "CONTENT_INVALID": ContentInvalidError,
    "COMMAND_UNKNOWN": CommandUnknownError,
    "FORWARD_FAILED": ForwardFailedError,
    "NAME_UNRESOLVED": NameUnresolvedError,
    "BIND_REFUSED": BindRefusedError,
    "WHITEBOARD_UNKNOWN": WhiteboardUnknownError,
    "AUTH_FAILED": AuthFailedError,
    "AUTH_REQUIRED": AuthRequiredError,
    "REGISTRATION_INVALID": RegistrationInvalidError,
    "PATTERN_INVALID": PatternInvalidError,
    "RETRIEVE_INVALID": RetrieveInvalidError,
    "QUEUE_OVERFLOW": QueueOverflowError,
    "DELIVERY_FAILED": DeliveryFailedError,
    "LIMIT_EXCEEDED": LimitExceededError,
    "STORE_FAILED": StoreFailedError,
    "SHUTTING_DOWN": ShuttingDownError,
    "STREAM_UNKNOWN": StreamUnknownError,
    "SAMPLE_UNKNOWN": SampleUnknownError,
    "SAMPLE_INVALID": SampleInvalidError,
    "LOCK_UNKNOWN": LockUnknownError,
    "API_MISUSE": ApiMisuseError,
    "CONNECTION_CLOSED": ConnectionClosedError,
    "REQUEST_TIMEOUT": RequestTimeoutError,
    "REQUEST_FAILED": RequestFailedError,
}


def error_for(name: str) -> type[OpenAIRError]:
    """Return the error class for a condition name (KeyError if unknown)."""
    return ERRORS[name]


__all__ = [
    "ERRORS",
    "ApiMisuseError",
    "AuthFailedError",
    "AuthRequiredError",
    "BinarySizesInvalidError",
    "BinaryTooLargeError",
    "BindRefusedError",
    "Blame",
    "CommandUnknownError",
    "ConnectionClosedError",
    "ContentInvalidError",
    "DeliveryFailedError",
    "ErrorCode",
    "ForwardFailedError",
    "FrameTooLargeError",
    "FrameTruncatedError",
    "FrameUnknownTagError",
    "LimitExceededError",
    "LocalProtocolError",
    "LockUnknownError",
    "MessageInvalidError",
    "NameUnresolvedError",
    "OpenAIRError",
    "PatternInvalidError",
    "PeerError",
    "QueueOverflowError",
    "RegistrationInvalidError",
    "RemoteProtocolError",
    "RequestFailedError",
    "RequestTimeoutError",
    "RetrieveInvalidError",
    "SampleInvalidError",
    "SampleUnknownError",
    "ShuttingDownError",
    "StoreFailedError",
    "StreamUnknownError",
    "TypeInvalidError",
    "WhiteboardUnknownError",
    "XmlForbiddenError",
    "XmlMalformedError",
    "XmlTooDeepError",
    "error_for",
]
