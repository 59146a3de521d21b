"""Replies of the router: the reply envelope, error replies and the information commands.

Pure functions over values; the router decides which to call. Every reply follows OA-SESS-1 /
OA-SESS-32: `isresponse` = the request's id, `to` = the request's `from`, `from` = the answering
component, `postedTime` = the `now_ns` the router was given.
"""

from __future__ import annotations

import itertools
import os
import random
from collections.abc import Callable, Iterator, Mapping
from datetime import UTC, datetime
from typing import TYPE_CHECKING

from openair.protocol.content import Dictionary, Phase
from openair.protocol.errors import OpenAIRError, StoreFailedError
from openair.protocol.message import Message
from openair.protocol.objects import (
    Capabilities,
    encode_capabilities,
    encode_dictionary,
    encode_time,
)
from openair.protocol.registration import encode_phase
from openair.protocol.times import AirTime
from openair.server.core.config import ServerConfig, ServerLimits

if TYPE_CHECKING:
    from concurrent.futures import Future

__all__ = [
    "KNOWN_EXTENSIONS",
    "capabilities_reply",
    "current_phase_reply",
    "declared_extensions",
    "entry_reply",
    "error_reply",
    "forward_failed",
    "fresh_id",
    "ms_time",
    "reply",
    "status_reply",
    "time_reply",
    "unknown_command",
]

#: The extension names of OpenAIR 1.0, in the order of the table of 15.2 (OA-EXT-1).
KNOWN_EXTENSIONS = (
    "noreply",
    "pipelining",
    "usec",
    "gettime",
    "durable",
    "typed-streams",
    "contexts",
    "auth",
    "monitor",
    "qos",
)
_KNOWN = frozenset(KNOWN_EXTENSIONS) - {"auth"}  # OA-EXT-4: auth is never declared
_NS_PER_MS = 1_000_000

# Ids need to be fresh, not secret (OA-MSG-8: a fresh UUID string for every message a sender
# creates): a random UUID-4 prefix drawn once per process (74 random bits) and a 48-bit counter
# in the last group make unique UUID-4-shaped strings at the cost of one formatting.
_random = random.Random()
_VERSION_MASK = ~((0xF000 << 64) | (0xC000 << 48))
_VERSION_BITS = (0x4000 << 64) | (0x8000 << 48)
_COUNTER_MASK = (1 << 48) - 1
_last_time: tuple[int, AirTime] = (-1, AirTime(sec=0))


def _new_id_source() -> tuple[str, Iterator[int]]:
    n = (_random.getrandbits(128) & _VERSION_MASK) | _VERSION_BITS
    h = f"{n:032x}"
    return f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-", itertools.count(n & _COUNTER_MASK)


_id_prefix, _id_counter = _new_id_source()


def _reseed() -> None:
    """Give a forked child its own prefix, so parent and child never share ids."""
    global _id_prefix, _id_counter
    _random.seed()
    _id_prefix, _id_counter = _new_id_source()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_reseed)


def fresh_id() -> str:
    """Return a fresh UUID-4 string (OA-MSG-8)."""
    return f"{_id_prefix}{next(_id_counter) & _COUNTER_MASK:012x}"


def ms_time(ns: int) -> AirTime:
    """Return `ns` as a millisecond time, reusing the last value within the same millisecond."""
    global _last_time
    ms = ns // _NS_PER_MS
    if _last_time[0] != ms:
        _last_time = (ms, AirTime.from_ms(ms))
    return _last_time[1]


def reply(
    req: Message, type_: str, *, sender: str, now_ns: int, content: str = "", xml: bool = False
) -> Message:
    """Build the reply `type_` to `req` from `sender` (OA-SESS-1, OA-SESS-32)."""
    return Message.trusted(  # no field here needs Message's validation (priority, wbid)
        type=type_,
        id=fresh_id(),
        sender=sender,
        to=req.sender,
        isresponse=req.id,  # OA-SESS-1
        posted=ms_time(now_ns),
        content=content,
        content_is_xml=xml,
        language="xml" if xml else "",
    )


def error_reply(
    req: Message, err: OpenAIRError, *, sender: str, now_ns: int, type_: str = ""
) -> Message:
    """Build the failure reply for `err`: `type_` or the table's, `NAME: detail` (OA-ERR-2/6)."""
    type_ = type_ or err.reply or "RECEIVE_ERROR"
    return reply(req, type_, sender=sender, now_ns=now_ns, content=err.wire_text())


def reply_when_stored(req: Message, sender: str) -> Callable[[Future[int], int], Message]:
    """The reply to a post once a cluster's store has it, or could not (OA-WB-3, OA-CLU-2):
    RECEIVE_ACCEPT, else STORE_FAILED (not stored, or not known to be)."""

    def failed(exc: BaseException, now_ns: int) -> Message:
        err = StoreFailedError(f"{sender}: {exc or type(exc).__name__}")
        return error_reply(req, err, sender=sender, now_ns=now_ns)

    return _accept_when_done(req, sender, failed)


def reply_when_forwarded(req: Message) -> Callable[[Future[int], int], Message]:
    """The reply to a message sent on to another cluster node's module (OA-CLU-8):
    RECEIVE_ACCEPT from the module once that node queued it, else FORWARD_FAILED."""
    return _accept_when_done(req, req.to, lambda _, now_ns: forward_failed(req, now_ns=now_ns))


def _accept_when_done(
    req: Message, sender: str, failed: Callable[[BaseException, int], Message]
) -> Callable[[Future[int], int], Message]:
    """RECEIVE_ACCEPT from `sender` once `done` succeeded, else `failed`'s reply."""

    def answer(done: Future[int], now_ns: int) -> Message:
        try:
            done.result(0)
        except BaseException as exc:
            return failed(exc, now_ns)
        return reply(req, "RECEIVE_ACCEPT", sender=sender, now_ns=now_ns)

    return answer


def unknown_command(req: Message, *, sender: str, now_ns: int) -> Message:
    """Answer a command the addressee does not know (OA-SESS-20, OA-SESS-29)."""
    return reply(
        req, "UNKNOWN_COMMAND", sender=sender, now_ns=now_ns, content=f"Offending cmd: {req.type}"
    )


def forward_failed(req: Message, *, now_ns: int) -> Message:
    """Answer a request whose `to` names nothing the server knows (OA-SESS-21)."""
    return reply(
        req,
        "FORWARD_FAILED",
        sender="CNS",
        now_ns=now_ns,
        content=f"Could not forward message to: {req.to}",
    )


def declared_extensions(msg: Message) -> frozenset[str] | None:
    """Return the extensions a module declared in its `extensions` slot (OA-SESS-19).

    None when the message has no such slot; unknown names are ignored (OA-EXT-1).
    """
    slot = msg.extra("extensions")
    if slot is None:
        return None
    return frozenset(name for name in slot.value.split() if name in _KNOWN)


def status_reply(
    req: Message,
    *,
    started_ns: int,
    now_ns: int,
    modules: int,
    counters: Mapping[str, object] | None = None,
) -> Message:
    """Answer STATUS with `Name` and `Created` (OA-SESS-25), a few counts and the counters.

    Counters are flattened to dotted entry names (`whiteboards.WB1.received`), so that a monitor
    can read every whiteboard's and module's figures over the protocol.
    """
    created = datetime.fromtimestamp(started_ns / 1e9, tz=UTC).isoformat(timespec="milliseconds")
    entries = [("Name", "CNS"), ("Created", created), ("Modules", str(modules))]
    entries.extend(_flatten(counters or {}, ""))
    content = encode_dictionary(Dictionary(entries=tuple(entries)))
    return reply(req, "STATUS_SUCCESS", sender="CNS", now_ns=now_ns, content=content, xml=True)


def _flatten(value: Mapping[str, object], prefix: str) -> list[tuple[str, str]]:
    """Flatten nested mappings to (dotted name, text) pairs, in order."""
    out: list[tuple[str, str]] = []
    for key, item in value.items():
        name = f"{prefix}{key}"
        if isinstance(item, Mapping):
            out.extend(_flatten(item, name + "."))
        else:
            out.append((name, str(item)))
    return out


def capabilities_reply(
    req: Message, *, server: str, extensions: frozenset[str], limits: ServerLimits, now_ns: int
) -> Message:
    """Answer GET_CAPABILITIES with the extensions and limits (OA-SESS-23, OA-CAP-1, OA-LIM-4)."""
    caps = Capabilities(
        server=server,
        extensions=tuple(e for e in KNOWN_EXTENSIONS if e in extensions),  # OA-CAP-3
        limits=limits.advertised(),
    )
    content = encode_capabilities(caps)
    return reply(req, "CAPABILITIES", sender="CNS", now_ns=now_ns, content=content, xml=True)


def time_reply(req: Message, *, usec: bool, now_ns: int) -> Message:
    """Answer GET_TIME with the server's clock as given (OA-EXT-2); usec if declared."""
    content = encode_time("time", AirTime.from_ns(now_ns, with_usec=usec))
    return reply(req, "TIME", sender="CNS", now_ns=now_ns, content=content, xml=True)


def entry_reply(req: Message, config: ServerConfig, *, now_ns: int) -> Message:
    """Answer GET_ENTRY: the Global dictionary, a module's `<module>`, or nothing (OA-SESS-12)."""
    key = req.content.strip()
    if key == "Global":
        entries = (
            ("spec", config.source),
            ("name", config.name),
            ("title", config.global_entry("title")),
            ("description", config.global_entry("description")),
            ("datastorefile", config.global_entry("datastorefile")),
            ("htmldir", config.global_entry("htmldir")),
        )
        content = encode_dictionary(Dictionary(entries=entries))
        return reply(req, "ENTRY", sender="Config", now_ns=now_ns, content=content, xml=True)
    module = config.module(key)
    if module is None:
        return reply(req, "ENTRY", sender="Config", now_ns=now_ns)
    return reply(req, "ENTRY", sender="Config", now_ns=now_ns, content=module.spec_xml, xml=True)


def current_phase_reply(req: Message, phase: Phase | None, *, now_ns: int) -> Message:
    """Answer CurrentPhase with the requester's phase in force, or nothing (OA-SESS-13)."""
    if phase is None:
        return reply(req, "Psyclone.Module.CurrentPhase", sender="Psyclone", now_ns=now_ns)
    content = encode_phase(phase, module=req.sender)
    type_ = "Psyclone.Module.CurrentPhase"
    return reply(req, type_, sender="Psyclone", now_ns=now_ns, content=content, xml=True)
