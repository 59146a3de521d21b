"""The Python shim with one behaviour broken on purpose: `python broken_client_shim.py MODE`.

Each mode patches the Python client (or the shim) in this process only, then runs the normal
shim, so that `openair conform-client` must catch exactly that fault. The modes and the
scenario expected to catch each are listed in `BREAKS` (the tests read it).
"""

from __future__ import annotations

import os
import sys
import uuid
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import openair.client.listener as listener
import openair.client.session as session
import openair.client.shim as shim
import openair.protocol.connection as connection
from openair.client.link import Link
from openair.client.module import Module
from openair.client.session import ClientConnection, Invalid, Request
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message

WAKEUP = "AIR.Instruct.Wakeup"


def no_callback() -> None:
    """Never open the callback connection (connect still says it did)."""

    async def open_callback(self: Any, host: str, port: int, notification: Message) -> None:
        return None

    listener.Listener.open_callback = open_callback  # type: ignore[method-assign]


def ping_accept() -> None:
    """Answer PING with RECEIVE_ACCEPT (the one answer table, in this shim's process only)."""
    connection.ANSWER_FOR.pop("PING")


def no_ack() -> None:
    """Never acknowledge a wakeup (the answer is computed, then not sent)."""
    original = ClientConnection.answer

    def answer(self: ClientConnection, request: Any, type: str | None = None, **kw: Any) -> bytes:
        data = original(self, request, type, **kw)
        if isinstance(request, Request) and request.message.type == WAKEUP:
            return b""
        return data

    ClientConnection.answer = answer  # type: ignore[method-assign]


def wrong_isresponse() -> None:
    """Acknowledge wakeups with an isresponse that names no request."""
    original = Message.reply

    def reply(self: Message, type: str, **kw: Any) -> Message:
        made = original(self, type, **kw)
        return replace(made, isresponse=str(uuid.uuid4())) if self.type == WAKEUP else made

    Message.reply = reply  # type: ignore[method-assign]


def lowercase_postedtime() -> None:
    """Write the legacy spelling `postedtime` instead of the canonical `postedTime`."""
    original: Callable[..., Frame] = getattr(session, "to_frame")  # noqa: B009

    def to_frame(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> Frame:
        frame = original(msg, tag)
        return replace(frame, xml=frame.xml.replace(b"<postedTime ", b"<postedtime "))

    setattr(session, "to_frame", to_frame)  # noqa: B010 -- the name session.py encodes with


def noreply_to_legacy() -> None:
    """Send noreply="yes" whatever the server advertised."""

    async def post_noreply(self: Module, msg: Message) -> Message:
        link = await self._wait_link()
        link.conn.extensions = link.conn.extensions | {"noreply"}
        return await link.send_noreply(replace(msg, noreply=True))

    Module._post_noreply = post_noreply  # type: ignore[method-assign]


def wrong_trigger() -> None:
    """Report the trigger message's from and to swapped, and lasttrigger as the type."""
    original = shim.wakeup_object

    def wakeup_object(event: Any) -> dict[str, Any]:
        found = original(event)
        trigger = found["trigger"]
        if trigger is not None:
            trigger["from"], trigger["to"] = trigger["to"], trigger["from"]
            found["lasttrigger"] = trigger["type"]
        return found

    shim.wakeup_object = wakeup_object


def crash_on_malformed() -> None:
    """Exit the process when a delivery cannot be parsed."""
    original = listener._answer

    async def answer(
        conn: Any, event: Any, handler: Any, received_ns: int, *rest: Any
    ) -> bytes | None:
        if isinstance(event, Invalid):
            os._exit(3)
        return await original(conn, event, handler, received_ns, *rest)

    listener._answer = answer


def pipelining_to_legacy() -> None:
    """Keep several requests in flight whatever the server advertised."""
    original = Link.set_window

    def set_window(self: Link, window: int) -> None:
        original(self, max(window, 8))

    Link.set_window = set_window  # type: ignore[method-assign]


def no_posted_time() -> None:
    """Send every message without postedTime."""

    def stamp(self: ClientConnection, msg: Message) -> Message:
        return msg

    ClientConnection._stamp = stamp  # type: ignore[method-assign]


#: mode -> (the patch, the scenario that must fail, a word its failure message contains)
BREAKS: dict[str, tuple[Callable[[], None], str, str]] = {
    "no-callback": (no_callback, "CLI-003", "callback"),
    "ping-accept": (ping_accept, "CLI-010", "RECEIVE_ACCEPT"),
    "no-ack": (no_ack, "CLI-013", "no answer"),
    "wrong-isresponse": (wrong_isresponse, "CLI-013", "isresponse"),
    "lowercase-postedtime": (lowercase_postedtime, "CLI-019", "postedtime"),
    "noreply-to-legacy": (noreply_to_legacy, "CLI-009", "noreply"),
    "wrong-trigger": (wrong_trigger, "CLI-004", "trigger.from"),
    "crash-on-malformed": (crash_on_malformed, "CLI-016", "closed"),
    "no-posted-time": (no_posted_time, "CLI-018", "postedTime"),
    "pipelining-to-legacy": (pipelining_to_legacy, "CLI-009", "in flight"),
}


def main(argv: list[str]) -> int:
    """Apply the break named in argv[1] and run the shim."""
    if len(argv) != 2 or argv[1] not in BREAKS:
        print(f"usage: {argv[0]} {{{','.join(BREAKS)}}}", file=sys.stderr)
        return 2
    BREAKS[argv[1]][0]()
    shim.LIBRARY = f"openair-python-broken-{argv[1]}"
    return shim.main()


if __name__ == "__main__":
    sys.exit(main(sys.argv))
