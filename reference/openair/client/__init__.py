"""The Python OpenAIR client: an async `Module`, a blocking wrapper and the sans-I/O session.

`Module` is the API for programs (async context manager, no threads); `BlockingModule` wraps it
for scripts; `ClientConnection` is the sans-I/O core both are built on (spec section 6).
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
    "Reply",
    "Request",
    "Role",
    "State",
    "WakeupEvent",
]
