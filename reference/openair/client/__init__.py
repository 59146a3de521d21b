"""The Python OpenAIR client: an async `Module`, a blocking wrapper and the sans-I/O session.

`Module` is the API for programs (async context manager, no threads); `BlockingModule` wraps it
for scripts; `ClientConnection` is the sans-I/O core both are built on (spec section 6).
Streams (spec 11): `Module.stream()` gives a `StreamHandle`, `Module.subscribe_stream()` a
`StreamSubscription` of `ReceivedSample`s, `Module.alarms()` the `StreamAlarm`s.
"""

from __future__ import annotations

from openair.client.blocking import BlockingModule
from openair.client.module import FailedReplyError, MessageEvent, Module, WakeupEvent
from openair.client.session import (
    CLIENT_EXTENSIONS,
    ClientConnection,
    Closed,
    Event,
    Invalid,
    Reply,
    Request,
    Role,
    State,
)
from openair.client.stream_push import StreamSubscription
from openair.client.stream_wire import ReceivedSample, StreamAlarm, StreamInfo
from openair.client.streams import StreamHandle, StreamLock

__all__ = [
    "CLIENT_EXTENSIONS",
    "BlockingModule",
    "ClientConnection",
    "Closed",
    "Event",
    "FailedReplyError",
    "Invalid",
    "MessageEvent",
    "Module",
    "ReceivedSample",
    "Reply",
    "Request",
    "Role",
    "State",
    "StreamAlarm",
    "StreamHandle",
    "StreamInfo",
    "StreamLock",
    "StreamSubscription",
    "WakeupEvent",
]
