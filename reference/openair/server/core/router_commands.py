"""The system components' commands of the router: CNS, Config, Psyclone, AIRServer (spec 6.2).

Binding, Receive frames, secure mode's challenge and response, name resolution, PING and
KEEPALIVE, STATUS and the counters it reports, capabilities, time, config entries, the stream
listing and creation, the current phase and the server's id and name. A part of `Router`
(`router_state` says how the parts fit); sans-I/O: time comes in as `now_ns`.
"""

from __future__ import annotations

from collections.abc import Mapping

from openair.protocol.auth import AUTH_ACCEPT, AUTH_NONCE
from openair.protocol.codec import to_frame
from openair.protocol.connection import answer_type
from openair.protocol.content import TcpLocation
from openair.protocol.errors import (
    BindRefusedError,
    MessageInvalidError,
    OpenAIRError,
    StreamUnknownError,
)
from openair.protocol.framing import FrameTag, encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import encode_tcplocation
from openair.server.core import commands as cmd
from openair.server.core.config import SYSTEM_COMPONENTS
from openair.server.core.outcome import Delivery, Handler, Outcome
from openair.server.core.router_state import RouterState
from openair.server.core.sessions import ConnId

__all__ = ["ComponentCommands"]

#: STATUS with counters of at least this many module names is written off the loop (issue #19).
_LARGE_STATUS = 2048


class ComponentCommands(RouterState):
    """The commands of the system components (a part of `Router`)."""

    def counters(self) -> dict[str, object]:
        """Return counters per whiteboard and per module, and a registration summary."""
        boards = {
            wb.name: {
                "received": wb.received,
                "stored": wb.stored,
                "dispatched": wb.dispatched,
                "evicted": wb.evicted,
                "count": len(wb),
                "next_wbid": wb.next_wbid,
            }
            for wb in self._whiteboards.values()
        }
        modules = {
            name: {
                "bound": name in self._modules,
                "requests": c.requests,
                "queued": c.queued,
                "delivered": c.delivered,
                "dropped": c.dropped,
            }
            for name, c in sorted(self._counters.items())
        }
        registrations = {
            name: {"triggers": len(t.entries), "retrieves": len(t.registration.retrieves)}
            for name, t in sorted(self._triggers.items())
        }
        streams = {
            name: {
                **stream.info(),
                "added": stream.added_total,
                "dropped": stream.dropped_total,
                "subscribers": self.streams.subscribers(name),
            }
            for name, stream in self.streams.streams.items()
        }
        return {
            "whiteboards": boards,
            "streams": streams,
            "modules": modules,
            "registrations": registrations,
            "bound": len(self._modules),
            "triggers": len(self._index),
            "notices_failed": self._lost_notices,
        }

    def rate_counters(self) -> dict[str, dict[str, int]]:
        """The counters a monitor samples for rates, at the cost of what is live (issue #19).

        `whiteboards` (received per whiteboard), `modules` (requests and delivered of the
        modules bound now: a module gone has no rate, however many names the retention keeps,
        OA-LIM-15) and `streams` (samples added per stream), each flat `kind:name` -> int.
        """
        counters = self._counters
        modules: dict[str, int] = {}
        for name in self._modules:
            c = counters.get(name)
            modules[f"out:{name}"] = c.requests if c is not None else 0
            modules[f"in:{name}"] = c.delivered if c is not None else 0
        return {
            "whiteboards": {f"wb:{wb.name}": wb.received for wb in self._whiteboards.values()},
            "modules": modules,
            "streams": {
                f"stream:{name}": stream.added_total
                for name, stream in self.streams.streams.items()
            },
        }

    def _component_tables(self) -> dict[str, dict[str, Handler]]:
        """Return each system component's commands (spec 6.2)."""
        session = {"PING": self._ping, "KEEPALIVE": self._keepalive}  # OA-SESS-10, OA-KEEP-2
        cns: dict[str, Handler] = {
            **session,
            "BIND": self._bind,
            "BIND_NOLISTEN": self._bind,
            "RECEIVE_NAME_NOTIFICATION": self._notification_in_message,
            "RESOLVE_REQUEST": self._resolve,
            "GET_STREAMS": self._get_streams,
            "STATUS": self._status,
            "GET_CAPABILITIES": self._capabilities,
        }
        if "gettime" in self.extensions:
            cns["GET_TIME"] = self._time  # OA-EXT-2 (only when advertised, OA-CAP-3)
        if self._auth is not None:  # OA-AUTH-2, OA-AUTH-3; legacy: UNKNOWN_COMMAND
            cns["AUTH_CHALLENGE"] = self._auth_challenge
            cns["AUTH_RESPONSE"] = self._auth_response
        return {
            "CNS": cns,
            "Config": {**session, "GET_ENTRY": self._entry},
            "Psyclone": {
                **session,
                "Psyclone.Module.Request.CurrentPhase": self._current_phase,
                **(
                    {"Psyclone.System.Create.Stream": self._create_stream}
                    if self.streams.typed
                    else {}
                ),
            },
            "AIRServer": {
                **session,
                "GET_ID": self._get_id,
                "GET_NAME": self._get_name,
                "System.PerfStat": self._perfstat,
            },
            "ContextsAndPhases": dict(session),
        }

    def _bind(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Bind a module name to this connection (OA-SESS-3..6, OA-SESS-19, OA-SESS-30)."""
        try:
            bound = self._sessions.bind(conn, msg, self.registration(msg.sender))
        except BindRefusedError as err:
            return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))
        deliveries: tuple[Delivery, ...] = ()
        if bound.took_over:  # OA-SESS-6: registration and queue kept, no Lost notice
            deliveries = self._notice(f"Psyclone.Module.Restored.{msg.sender}", now_ns)
        content = str(bound.port)
        accept = cmd.reply(msg, "BIND_ACCEPT", sender="CNS", now_ns=now_ns, content=content)
        return Outcome(replies=(accept,), deliveries=deliveries, close_conns=bound.close)

    def _reserved(self, name: str) -> bool:
        """Return whether `name` belongs to a whiteboard, stream or component (OA-SESS-30)."""
        return (
            name in self._whiteboards
            or name in self.streams.names()
            or name in SYSTEM_COMPONENTS
            or name in self._internal  # OA-CONF-8: an internal module's name
        )

    def _receive_frame(self, conn: ConnId, msg: Message, now_ns: int) -> Outcome:
        """Make `conn` the callback connection of `from` (OA-SESS-7); no reply."""
        if msg.type != "RECEIVE_NAME_NOTIFICATION":
            err = MessageInvalidError("a Receive frame must carry RECEIVE_NAME_NOTIFICATION")
            return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))
        if msg.to and msg.to not in SYSTEM_COMPONENTS and msg.to not in self._whiteboards:
            stream = self.streams.subscribe_push(conn, msg)  # 11.6: a push connection
            if stream is not None:
                return Outcome(push_stream=stream)
            err2 = StreamUnknownError(f"no stream {msg.to!r} to receive samples from")
            return Outcome(replies=(self._error(msg, err2, "CNS", now_ns),))
        close = self._sessions.notify(conn, msg)
        if close is None:
            return Outcome(close_this=True)  # no module can ever bind that name
        return Outcome(close_conns=close)

    def _auth_screen(
        self, conn: ConnId, msg: Message, tag: FrameTag, now_ns: int
    ) -> Outcome | None:
        """Refuse what this connection may not do in secure mode (OA-AUTH-5, -6, -8)."""
        assert self._auth is not None
        to = msg.to or "CNS"
        board = to in self._whiteboards
        # A whiteboard answers PING and KEEPALIVE itself: only a bound module makes them posts.
        stored = board and msg.type not in ("PING", "KEEPALIVE")
        post = stored or (to not in self._components and to in self._modules)
        refusal = self._auth.screen(
            conn, msg, receive=tag is FrameTag.RECEIVE, cns=to == "CNS", post=post
        )
        if refusal is None:
            return None
        sender = to if board or to in self._components else "CNS"
        answer = cmd.error_reply(
            msg, refusal.error, sender=sender, now_ns=now_ns, type_=refusal.reply_type
        )
        return Outcome(replies=(answer,), close_this=refusal.close)

    def _auth_challenge(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Answer a fresh nonce for this connection (OA-AUTH-2)."""
        assert self._auth is not None
        nonce = self._auth.challenge(conn)
        return Outcome(
            replies=(cmd.reply(msg, AUTH_NONCE, sender="CNS", now_ns=now_ns, content=nonce),)
        )

    def _auth_response(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Prove `from` on this connection, or answer AUTH_FAILED (OA-AUTH-3)."""
        assert self._auth is not None
        try:
            self._auth.respond(conn, msg.sender, msg.content)
        except OpenAIRError as err:
            return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))
        return Outcome(replies=(cmd.reply(msg, AUTH_ACCEPT, sender="CNS", now_ns=now_ns),))

    def _notification_in_message(
        self, conn: ConnId, msg: Message, received_ns: int, now_ns: int
    ) -> Outcome:
        """Refuse RECEIVE_NAME_NOTIFICATION outside a Receive frame: it would need no reply."""
        err = MessageInvalidError("RECEIVE_NAME_NOTIFICATION must come in a Receive frame")
        return Outcome(replies=(self._error(msg, err, "CNS", now_ns),))

    def _resolve(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Resolve a name to the main port (OA-SESS-8, OA-SESS-9)."""
        name = msg.content.strip()
        known = (
            name in SYSTEM_COMPONENTS
            or name in self._whiteboards
            or self.streams.resolve(name) is not None  # OA-XSTREAM-1: a type resolves too
            or name in self._modules  # forwarded through the main port (OA-SESS-22)
        )
        if not known:  # NAME_UNRESOLVED: RESOLVE_FAILED keeps its legacy empty content (OA-ERR-6)
            return Outcome(replies=(cmd.reply(msg, "RESOLVE_FAILED", sender="CNS", now_ns=now_ns),))
        location = encode_tcplocation(TcpLocation(address=self.address, port=self.port, name=name))
        answer = cmd.reply(
            msg, "RESOLVE_SUCCESS", sender="CNS", now_ns=now_ns, content=location, xml=True
        )
        return Outcome(replies=(answer,))

    def _session_reply(self, msg: Message, sender: str, now_ns: int) -> Outcome:
        kind = answer_type(msg.type)  # OA-SESS-10, OA-KEEP-2: the one table
        return Outcome(replies=(cmd.reply(msg, kind, sender=sender, now_ns=now_ns),))

    def _ping(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        return self._session_reply(msg, msg.to or "CNS", now_ns)  # OA-SESS-10

    def _keepalive(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        return self._session_reply(msg, msg.to or "CNS", now_ns)  # OA-KEEP-2

    def _status(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        started = self.started_ns if self.started_ns is not None else now_ns
        modules = len(self._modules)
        counters = dict(self.counters())
        if self.status_extra is not None:
            counters.update(self.status_extra())
        if self._qos:  # OA-DELIV-14: the adapter counts expired deliveries among its drops
            dropped = counters.get("dropped")
            expired = dropped.get("EXPIRED", 0) if isinstance(dropped, Mapping) else 0
            counters["Deliveries"] = {"Expired": expired}
        if self.defer_large_replies and len(self._counters) >= _LARGE_STATUS:
            # Thousands of names take a second to write: built and encoded on a worker (issue
            # #19, item 7). The counters are a copy taken now, so the reply is of this moment.
            def later() -> tuple[Message, bytes | None]:
                reply = cmd.status_reply(
                    msg, started_ns=started, now_ns=now_ns, modules=modules, counters=counters
                )
                return reply, encode_frame(to_frame(reply))

            return Outcome(later=later)
        answer = cmd.status_reply(
            msg, started_ns=started, now_ns=now_ns, modules=modules, counters=counters
        )
        return Outcome(replies=(answer,))  # OA-SESS-25

    def _capabilities(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.capabilities_reply(
            msg,
            server=self.server_name,
            extensions=self.extensions,
            limits=self.limits,
            now_ns=now_ns,
        )
        return Outcome(replies=(answer,))  # OA-SESS-23, OA-CAP-1

    def _time(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Answer GET_TIME; with usec when the requester declared it (OA-EXT-2, OA-TIME-5)."""
        declared = self._sessions.extensions_of(conn, msg.sender)
        usec = "usec" in declared and "usec" in self.extensions
        return Outcome(replies=(cmd.time_reply(msg, usec=usec, now_ns=now_ns),))

    def _entry(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        return Outcome(replies=(cmd.entry_reply(msg, self.config, now_ns=now_ns),))  # OA-SESS-12

    def _get_streams(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """List the streams (OA-STREAM-16)."""
        listing = self.streams.listing()
        answer = cmd.reply(msg, "STREAMS", sender="CNS", now_ns=now_ns, content=listing, xml=True)
        return Outcome(replies=(answer,))

    def _create_stream(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Create a stream at run time (OA-XSTREAM-10)."""
        try:
            self.streams.create(
                msg.content,
                whiteboards=self._whiteboards,
                taken=lambda name: self._reserved(name) or name in self._modules,
            )
        except OpenAIRError as err:
            return Outcome(replies=(self._error(msg, err, "Psyclone", now_ns),))
        return Outcome(
            replies=(cmd.reply(msg, "RECEIVE_ACCEPT", sender="Psyclone", now_ns=now_ns),)
        )

    def _current_phase(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        reg = self.registration(msg.sender)
        phase = self._phase_in_force(msg.sender, reg)  # OA-REG-14 under `contexts`
        return Outcome(replies=(cmd.current_phase_reply(msg, phase, now_ns=now_ns),))  # OA-SESS-13

    def _get_id(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.reply(msg, "ID", sender="AIRServer", now_ns=now_ns, content=self.server_id)
        return Outcome(replies=(answer,))  # OA-SESS-14

    def _get_name(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.reply(msg, "NAME", sender="AIRServer", now_ns=now_ns, content=self.config.name)
        return Outcome(replies=(answer,))  # OA-SESS-14

    def _perfstat(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        answer = cmd.reply(msg, "RECEIVE_ACCEPT", sender="AIRServer", now_ns=now_ns)
        return Outcome(replies=(answer,))  # OA-SESS-14: the content may be ignored
