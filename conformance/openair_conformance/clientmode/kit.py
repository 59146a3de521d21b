"""The kit's own parts in a client scenario: a client of the server, and the requests it delivers.

`KitClient` is "another module": an unbound client (OA-SESS-16) on its own connection straight to
the server (not through the tap), which posts messages for the library to be woken by and reads
whiteboards to see what the library posted. `delivery` builds the requests the kit sends to the
module when it plays a server component (PING, KEEPALIVE, a wakeup, a phase update, malformed
XML). `message_json` renders a message as the shim protocol's message object, so that the same
paths (`messages[0].id`) work on the kit's results and on the shim's.
"""

from __future__ import annotations

import asyncio
import uuid
from dataclasses import replace
from typing import Any

from openair.protocol.codec import to_frame
from openair.protocol.content import Phase, RetrieveSpec
from openair.protocol.errors import OpenAIRError
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair.protocol.objects import parse_message_collection
from openair.protocol.registration import encode_retrieve
from openair.protocol.times import AirTime
from openair.protocol.wakeup import build_wakeup
from openair_conformance.harness.conn import (
    ConnectionLost,
    DecodeProblem,
    RequesterChannel,
    open_stream,
)
from openair_conformance.harness.trace import Trace
from openair_conformance.model import Inconclusive

__all__ = ["DEFAULT_REPLY", "KitClient", "delivery", "message_json"]

#: The answer each kind of delivery must get (OA-SESS-11, OA-KEEP-2, OA-DELIV-4, OA-ERR-3).
DEFAULT_REPLY = {
    "ping": "PING_SUCCESS",
    "keepalive": "KEEPALIVESUCCESS",
    "wakeup": "RECEIVE_ACCEPT",
    "phase-update": "RECEIVE_ACCEPT",
    "malformed": "RECEIVE_ERROR",
}


def _time(value: AirTime | None) -> list[int] | None:
    return None if value is None else [value.sec, value.msec]


def message_json(msg: Message) -> dict[str, Any]:
    """Return `msg` as the shim protocol's message object (PROTOCOL.md)."""
    return {
        "type": msg.type,
        "id": msg.id,
        "from": msg.sender,
        "to": msg.to,
        "cc": msg.cc,
        "stored": msg.stored,
        "isresponse": msg.isresponse,
        "posted": _time(msg.posted),
        "received": _time(msg.received),
        "priority": msg.priority,
        "wbid": msg.wbid,
        "content": msg.content,
        "xml": msg.content_is_xml,
    }


class KitClient:
    """The kit's connection to the server; opened on first use, traced as `kit`."""

    def __init__(self, server: tuple[str, int], trace: Trace, *, name: str, timeout: float) -> None:
        self.server = server
        self.trace = trace
        self.name = name
        self.timeout = timeout
        self._channel: RequesterChannel | None = None

    async def _open(self) -> RequesterChannel:
        if self._channel is None:
            stream = await open_stream(
                *self.server, label="kit", trace=self.trace, timeout=self.timeout
            )
            self._channel = RequesterChannel(stream, name=self.name, pipelining=False)
            self._channel.start()
        return self._channel

    async def request(self, msg: Message) -> tuple[Message, Message]:
        """Send a request and return it as sent with its reply; Inconclusive if that fails."""
        try:
            channel = await self._open()
            sent, future = await channel.send(msg)
            reply = await asyncio.wait_for(future, self.timeout)
        except (ConnectionLost, DecodeProblem, TimeoutError) as exc:
            raise Inconclusive(f"the kit's own {msg.type} failed: {exc or 'timeout'}") from exc
        return sent, reply

    async def post(
        self, to: str, type_: str, content: str = "", *, cc: str = "", priority: float | None = None
    ) -> Message:
        """Post a message; Inconclusive unless RECEIVE_ACCEPT (the server refused the setup)."""
        msg = Message(
            type=type_, sender=self.name, to=to, cc=cc, content=content, priority=priority
        )
        sent, reply = await self.request(msg)
        if reply.type != "RECEIVE_ACCEPT":
            raise Inconclusive(f"the server answered the kit's post with {reply.type}")
        return sent

    async def retrieve(self, whiteboard: str, pattern: str, latest: int) -> list[Message]:
        """Read `whiteboard` (newest first); Inconclusive unless AIR.Retrieve.Success."""
        spec = RetrieveSpec(whiteboard=whiteboard, pattern=pattern, latest=latest)
        msg = Message(
            type="AIR.Retrieve",
            sender=self.name,
            to=whiteboard,
            language="xml",
            content=encode_retrieve(spec),
            content_is_xml=True,
        )
        _, reply = await self.request(msg)
        if reply.type != "AIR.Retrieve.Success":
            raise Inconclusive(f"the server answered the kit's retrieve with {reply.type}")
        try:
            return list(parse_message_collection(reply.content)) if reply.content.strip() else []
        except OpenAIRError as exc:
            raise Inconclusive(f"the kit cannot read its retrieve result: {exc}") from exc

    async def close(self) -> None:
        """Close the connection (if it was opened)."""
        if self._channel is not None:
            await self._channel.close()


def _stamp(msg: Message, now_ns: int) -> Message:
    return replace(msg, posted=AirTime.from_ns(now_ns))  # OA-TIME-2, no usec (OA-GEN-2)


def delivery(
    kind: str,
    *,
    module: str,
    whiteboard: str,
    trigger_type: str,
    lasttrigger: str,
    sender: str,
    now_ns: int,
) -> tuple[Frame, Message | None]:
    """Build the request of one `deliver` step: its frame and (unless malformed) its message."""
    if kind == "ping":
        msg = Message(type="PING", sender="CNS", to=module)
    elif kind == "keepalive":
        msg = Message(type="KEEPALIVE")  # OA-KEEP-1: empty from and to
    elif kind == "wakeup":
        stored = Message(
            type=trigger_type,
            sender=sender,
            to=whiteboard,
            stored=whiteboard,
            content="delivered by the kit",
            posted=AirTime.from_ns(now_ns),
            received=AirTime.from_ns(now_ns),
            wbid=1,
        )
        msg = build_wakeup(
            stored=stored, whiteboard=whiteboard, module=module, lasttrigger=lasttrigger
        )
    elif kind == "phase-update":
        phase = Phase(name="Default Phase")
        msg = build_wakeup(stored=None, whiteboard="ContextsAndPhases", module=module, phase=phase)
    elif kind == "malformed":
        xml = f"<message><type>PING</type><id>{uuid.uuid4()}</id><from>CNS</from".encode()
        return Frame(tag=FrameTag.MESSAGE, xml=xml), None
    else:
        raise ValueError(f"no delivery kind {kind!r}")
    msg = _stamp(msg, now_ns)
    return to_frame(msg), msg
