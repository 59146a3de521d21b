"""Mutants of sessions, delivery and the wire (spec sections 2, 6, 10, 13-15).

Reply mutants patch the reply builders of `openair.server.core.commands` (the router calls them as
`cmd.<name>`); session mutants wrap `Sessions`; connection mutants wrap `ServerConnection` and
the codec functions as `openair.server.aio.protocol` imports them (the harness keeps its own).
"""

from __future__ import annotations

import itertools
import re
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest
from mutants_core import WAKEUP, Fn, mutant, outcome_patch, with_message, wrap

from openair.protocol.codec import from_frame
from openair.protocol.errors import RemoteProtocolError
from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair.protocol.xmlsafe import XmlLimits
from openair.server.aio import delivery, protocol, responder, timers, writer
from openair.server.core import commands, retrieve, sessions
from openair.server.core.config import ServerLimits
from openair.server.core.queues import DeliveryQueue
from openair.server.core.router import Outcome, Router

# --- delivery order (sections 6.6, 10) -----------------------------------------------------------


def _priority_patch(mp: pytest.MonkeyPatch, priority: Callable[[float], float]) -> None:
    outcome_patch(mp, lambda self, d: (replace(d, priority=priority(d.priority)),))


@mutant("priority-ignored", "deliveries leave in arrival order, whatever the priority", "OA-PRIO-1")
def _priority_ignored(mp: pytest.MonkeyPatch) -> None:
    _priority_patch(mp, lambda p: 2.0)


@mutant("lifo-within-priority", "within a priority the newest delivery leaves first", "OA-PRIO-1")
def _lifo(mp: pytest.MonkeyPatch) -> None:
    seq = itertools.count()
    _priority_patch(mp, lambda p: p - next(seq) * 1e-9)


@mutant("window-ignored", "a legacy module gets many deliveries in flight", "OA-DELIV-5")
def _window(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(delivery.ModuleDelivery, "_window", lambda self: self._d.max_in_flight)


@mutant(
    "overflow-drops-newest",
    "a full queue drops the newest of its lowest-priority items",
    "OA-DELIV-9",
    limits={"max_queue": 300},
)
def _drop_newest(mp: pytest.MonkeyPatch) -> None:
    def _drop_one(self: DeliveryQueue) -> Any:
        worst = max(self._items.values(), key=lambda item: (item.priority, item.seq))
        del self._items[worst.seq]
        self._waiting.discard(worst.seq)
        self.counters.dropped += 1
        return worst

    mp.setattr(DeliveryQueue, "_drop_one", _drop_one)


# --- sessions and replies (section 6) ------------------------------------------------------------


@mutant("isresponse-empty", "replies carry an empty isresponse", "OA-SESS-1")
def _isresponse(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def reply(req: Message, type_: str, **kwargs: Any) -> Message:
            answer: Message = original(req, type_, **kwargs)
            return replace(answer, isresponse="")

        return reply

    wrap(mp, commands, "reply", make)
    mp.setattr(retrieve, "reply", commands.reply)


@mutant("replies-reversed", "requests that arrive together are answered last first", "OA-SESS-2")
def _replies_reversed(mp: pytest.MonkeyPatch) -> None:
    conn = protocol.ServerConnection
    send = conn.send

    def send_(self: Any, msg: Message, *args: Any, **kwargs: Any) -> bool:
        held = self.__dict__.get("_mutant_held")
        if held is None or self.role is not protocol.Role.RESPONDER:
            return bool(send(self, msg, *args, **kwargs))
        held.append((msg, args, kwargs))
        return True

    def make(original: Fn) -> Fn:
        def data_received(self: Any, data: bytes) -> None:
            self._mutant_held = []
            try:
                original(self, data)
            finally:
                held, self._mutant_held = self._mutant_held, None
                for msg, args, kwargs in reversed(held):
                    send(self, msg, *args, **kwargs)

        return data_received

    mp.setattr(conn, "send", send_)
    wrap(mp, conn, "data_received", make)


@mutant("unknown-command-accepted", "an unknown command is answered RECEIVE_ACCEPT", "OA-SESS-20")
def _unknown_accepted(mp: pytest.MonkeyPatch) -> None:
    def unknown(req: Message, *, sender: str, now_ns: int) -> Message:
        return commands.reply(req, "RECEIVE_ACCEPT", sender=sender, now_ns=now_ns)

    mp.setattr(commands, "unknown_command", unknown)


@mutant("forward-failed-missing", "a request to nobody is answered RECEIVE_ACCEPT", "OA-SESS-21")
def _forward_failed(mp: pytest.MonkeyPatch) -> None:
    def forward_failed(req: Message, *, now_ns: int) -> Message:
        return commands.reply(req, "RECEIVE_ACCEPT", sender="CNS", now_ns=now_ns)

    mp.setattr(commands, "forward_failed", forward_failed)


@mutant("takeover-keeps-old", "a takeover BIND leaves the old connections open", "OA-SESS-6")
def _takeover(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def bind(self: sessions.Sessions, *args: Any) -> sessions.Bound:
            bound: sessions.Bound = original(self, *args)
            return replace(bound, close=())

        return bind

    wrap(mp, sessions.Sessions, "bind", make)


@mutant("callback-not-replaced", "an older callback connection is not closed", "OA-SESS-7")
def _callback(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def notify(self: sessions.Sessions, *args: Any) -> Any:
            close = original(self, *args)
            return None if close is None else ()

        return notify

    wrap(mp, sessions.Sessions, "notify", make)


@mutant("lost-notice-missing", "no Psyclone.Module.Lost when a module goes", "OA-SESS-15")
def _lost(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _notice(self: Router, type_: str, now_ns: int) -> Any:
            if type_.startswith("Psyclone.Module.Lost."):
                return ()
            return original(self, type_, now_ns)

        return _notice

    wrap(mp, Router, "_notice", make)


@mutant("keepalive-unanswered", "KEEPALIVE gets no reply", "OA-KEEP-2")
def _keepalive(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _session_reply(self: Router, msg: Message, sender: str, now_ns: int) -> Outcome:
            if msg.type == "KEEPALIVE":
                return Outcome()
            result: Outcome = original(self, msg, sender, now_ns)
            return result

        return _session_reply

    wrap(mp, Router, "_session_reply", make)


def _port_patch(mp: pytest.MonkeyPatch, change: Callable[[Any, int, Message, int], int]) -> None:
    def make(original: Fn) -> Fn:
        def _port(self: sessions.Sessions, conn: int, msg: Message) -> int:
            return change(self, conn, msg, original(self, conn, msg))

        return _port

    wrap(mp, sessions.Sessions, "_port", make)


@mutant("bind-port-ignored", "BIND with a tcplocation gets another port", "OA-SESS-4")
def _bind_port(mp: pytest.MonkeyPatch) -> None:
    def change(self: Any, conn: int, msg: Message, port: int) -> int:
        return port + 1 if msg.type == "BIND" and msg.content.strip() else port

    _port_patch(mp, change)


@mutant("bind-nolisten-port", "BIND_NOLISTEN is answered with a port, not -1", "OA-SESS-5")
def _nolisten(mp: pytest.MonkeyPatch) -> None:
    _port_patch(mp, lambda self, conn, msg, port: 10114 if port == -1 else port)


@mutant("status-no-created", "STATUS_SUCCESS lacks Created", "OA-SESS-25")
def _status(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def status(req: Message, **kwargs: Any) -> Message:
            msg: Message = original(req, **kwargs)
            content = re.sub(r'<entry name="Created">[^<]*</entry>', "", msg.content)
            return replace(msg, content=content)

        return status

    wrap(mp, commands, "status_reply", make)


# --- frames, hostile input and capabilities (sections 2, 13-15) ---------------------------------


@mutant("malformed-kills-connection", "malformed XML closes the connection", "OA-ERR-3")
def _malformed(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _on_request(self: Any, frame: Frame, received_ns: int) -> None:
            if frame.tag is not FrameTag.BINARY:
                try:
                    from_frame(frame, self.conn.host.limits.xml_limits())
                except RemoteProtocolError:
                    self.conn.abort()
                    return
            original(self, frame, received_ns)

        return _on_request

    wrap(mp, responder.Responder, "on_request", make)


@mutant("doctype-ignored", "a DOCTYPE is dropped instead of refused", "OA-SEC-1")
def _doctype(mp: pytest.MonkeyPatch) -> None:
    doctype = re.compile(rb"<!DOCTYPE[^\[>]*(\[.*?\])?\s*>", re.DOTALL | re.IGNORECASE)

    def make(original: Fn) -> Fn:
        def decode(frame: Frame, limits: Any = None) -> Message:
            frame = Frame(tag=frame.tag, xml=doctype.sub(b"", frame.xml), chunks=frame.chunks)
            result: Message = original(frame, limits)
            return result

        return decode

    wrap(mp, responder, "from_frame", make)


@mutant(
    "oversized-frame-kept-open",
    "FRAME_TOO_LARGE is answered but the connection stays open",
    "OA-FRAME-7",
)
def _oversized(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _framing_error(self: Any, exc: RemoteProtocolError) -> None:
            if exc.reply and self.role is protocol.Role.RESPONDER:
                self.send(writer.error_reply(self.name, exc.reply, exc.wire_text()))
                return
            original(self, exc)

        return _framing_error

    wrap(mp, protocol.ServerConnection, "_framing_error", make)


@mutant(
    "frame-deadline-ignored",
    "a stalled frame never closes the connection",
    "OA-FRAME-12",
    limits={"frame_deadline_ms": 400},
)
def _deadline(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(timers.ConnectionTimers, "check_deadline", lambda self: None)


@mutant("wbid-unpadded", "wbid is written without zero padding", "OA-MSG-13")
def _wbid_unpadded(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def to_frame(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> Frame:
            frame: Frame = original(msg, tag)
            xml = re.sub(rb"<wbid>0+(?=[0-9])", b"<wbid>", frame.xml)
            return Frame(tag=frame.tag, xml=xml, chunks=frame.chunks)

        return to_frame

    wrap(mp, writer, "to_frame", make)


@mutant("gettime-usec-always", "GET_TIME has usec though the module did not declare it", "OA-GEN-2")
def _usec(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def time_reply(req: Message, *, usec: bool, now_ns: int) -> Message:
            result: Message = original(req, usec=True, now_ns=now_ns)
            return result

        return time_reply

    wrap(mp, commands, "time_reply", make)


@mutant("capabilities-missing-limit", "CAPABILITIES omits frame-deadline-ms", "OA-LIM-4")
def _caps(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def advertised(self: ServerLimits) -> tuple[tuple[str, int], ...]:
            return tuple(kv for kv in original(self) if kv[0] != "frame-deadline-ms")

        return advertised

    wrap(mp, ServerLimits, "advertised", make)


def _reply_patch(
    mp: pytest.MonkeyPatch, change: Callable[[Message, Any, Message], Message]
) -> None:
    """Let `change(request, tag, reply)` rewrite every reply the router makes."""

    def make(original: Fn) -> Fn:
        def handle(self: Router, conn: int, msg: Message, **kwargs: Any) -> Outcome:
            outcome: Outcome = original(self, conn, msg, **kwargs)
            replies = tuple(change(msg, kwargs.get("tag"), r) for r in outcome.replies)
            return replace(outcome, replies=replies)

        return handle

    wrap(mp, Router, "handle", make)


@mutant("resolve-anything", "RESOLVE_REQUEST of an unknown name succeeds", "OA-SESS-8")
def _resolve_anything(mp: pytest.MonkeyPatch) -> None:
    def change(req: Message, tag: Any, reply: Message) -> Message:
        if reply.type != "RESOLVE_FAILED":
            return reply
        content = f'<tcplocation address="127.0.0.1" port="10000" name="{req.content.strip()}"/>'
        return replace(
            reply, type="RESOLVE_SUCCESS", content=content, content_is_xml=True, language="xml"
        )

    _reply_patch(mp, change)


@mutant("empty-to-not-cns", "a request with an empty to is answered FORWARD_FAILED", "OA-SESS-26")
def _empty_to(mp: pytest.MonkeyPatch) -> None:
    def change(req: Message, tag: Any, reply: Message) -> Message:
        if req.to or tag is FrameTag.RECEIVE:
            return reply
        return commands.forward_failed(req, now_ns=time.time_ns())

    _reply_patch(mp, change)


@mutant(
    "bad-receive-frame-ignored",
    "a Receive frame of another type is silently ignored",
    "OA-FRAME-10",
)
def _receive_ignored(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def handle(self: Router, conn: int, msg: Message, **kwargs: Any) -> Outcome:
            outcome: Outcome = original(self, conn, msg, **kwargs)
            if kwargs.get("tag") is FrameTag.RECEIVE and msg.type != "RECEIVE_NAME_NOTIFICATION":
                return replace(outcome, replies=())
            return outcome

        return handle

    wrap(mp, Router, "handle", make)


@mutant("bind-bad-name-accepted", "BIND accepts names with white space or ';'", "OA-SESS-30")
def _bad_name(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(sessions, "name_problem", lambda name: None if name else "the name is empty")


@mutant("restored-notice-missing", "no Psyclone.Module.Restored after a takeover", "OA-SESS-6")
def _restored(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _notice(self: Router, type_: str, now_ns: int) -> Any:
            if type_.startswith("Psyclone.Module.Restored."):
                return ()
            return original(self, type_, now_ns)

        return _notice

    wrap(mp, Router, "_notice", make)


@mutant("forward-drops-slots", "messages forwarded to a module lose unknown slots", "OA-SESS-22")
def _forward_drops(mp: pytest.MonkeyPatch) -> None:
    def change(self: Router, d: Any) -> Any:
        if d.message.type == WAKEUP or not d.message.extras:
            return (d,)
        return (with_message(d, replace(d.message, extras=())),)

    outcome_patch(mp, change)


@mutant("binary-frame-ignored", "a BinaryM frame on the main port gets no reply", "OA-FRAME-5")
def _binary_ignored(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _on_request(self: Any, frame: Frame, received_ns: int) -> None:
            if frame.tag is not FrameTag.BINARY:
                original(self, frame, received_ns)

        return _on_request

    wrap(mp, responder.Responder, "on_request", make)


@mutant("xml-depth-off-by-one", "XML one level deeper than max-xml-depth is accepted", "OA-LIM-3")
def _depth(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def xml_limits(self: ServerLimits) -> XmlLimits:
            limits: XmlLimits = original(self)
            return replace(limits, max_depth=limits.max_depth + 1)

        return xml_limits

    wrap(mp, ServerLimits, "xml_limits", make)


@mutant("capabilities-advertise-auth", "CAPABILITIES advertises auth", "OA-EXT-4")
def _auth(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def capabilities(req: Message, *, extensions: frozenset[str], **kwargs: Any) -> Message:
            result: Message = original(req, extensions=extensions | {"auth"}, **kwargs)
            return result

        return capabilities

    wrap(mp, commands, "capabilities_reply", make)
