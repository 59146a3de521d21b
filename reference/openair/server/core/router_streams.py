"""Requests to streams and the alarms streams post, on the router's side (spec 11).

Media commands and BinaryM frames go to `StreamService`; its alarms (OA-XSTREAM-6) become
ordinary posts on their whiteboard; `stream_specs` reads the configured streams. A part of
`Router` (`router_state` says how the parts fit); sans-I/O: time comes in as `now_ns`.
"""

from __future__ import annotations

from openair.protocol.content import Dictionary
from openair.protocol.errors import OpenAIRError, StreamUnknownError
from openair.protocol.matching import ascii_fold
from openair.protocol.message import Message
from openair.protocol.objects import encode_dictionary
from openair.server.core import commands as cmd
from openair.server.core.config import ConfigError, ServerConfig
from openair.server.core.outcome import Delivery, Outcome
from openair.server.core.router_state import RouterState
from openair.server.core.sessions import ConnId
from openair.server.core.streamservice import StreamOutcome
from openair.server.core.streamspec import Alarm, StreamSpec

__all__ = ["StreamRouting", "stream_specs"]


class StreamRouting(RouterState):
    """Requests to streams, BinaryM frames, waits, ticks and alarms (a part of `Router`)."""

    def _to_stream(self, conn: ConnId, msg: Message, received_ns: int, now_ns: int) -> Outcome:
        """Answer a request to a stream: PING, KEEPALIVE and the media commands (spec 11)."""
        if msg.type in ("PING", "KEEPALIVE"):
            return self._session_reply(msg, msg.to, now_ns)
        result = self.streams.request(conn, msg, received_ns=received_ns, now_ns=now_ns)
        return self._stream_outcome(result, now_ns)

    def handle_binary(
        self, conn: ConnId, chunk: bytes, *, received_ns: int, now_ns: int
    ) -> Outcome:
        """Answer a BinaryM frame: a sample for the connection's current stream (OA-STREAM-11)."""
        request = Message(type="BinaryOnly", id="")  # what Psyclone calls a bare BinaryM
        if self._shutting_down:  # OA-SESS-24
            return self._refuse_shutting_down(request, now_ns)
        result = self.streams.binary(conn, chunk, received_ns=received_ns, now_ns=now_ns)
        if result is None:
            return Outcome(replies=(cmd.unknown_command(request, sender="CNS", now_ns=now_ns),))
        return self._stream_outcome(result, now_ns)

    def wait_expired(self, ticket: int, now_ns: int) -> Outcome:
        """Answer a WAIT_FOR_* whose timeout passed (OA-STREAM-7)."""
        ready = self.streams.wait_expired(ticket, now_ns)
        return Outcome(resolved=(ready,)) if ready is not None else Outcome()

    def tick(self, now_ns: int) -> Outcome:
        """Post the Idle alarms that fell due (OA-XSTREAM-7); the adapter calls it on a timer."""
        alarms = self.streams.tick(now_ns)
        return Outcome(deliveries=self._post_alarms(alarms, now_ns)) if alarms else Outcome()

    def _stream_outcome(self, result: StreamOutcome, now_ns: int) -> Outcome:
        deliveries = self._post_alarms(result.alarms, now_ns) if result.alarms else ()
        return Outcome(
            replies=result.replies,
            deliveries=deliveries,
            wait=result.wait,
            resolved=result.resolved,
            pushes=result.pushes,
        )

    def _post_alarms(self, alarms: tuple[Alarm, ...], now_ns: int) -> tuple[Delivery, ...]:
        """Post stream alarms as ordinary posts on their whiteboard (OA-XSTREAM-6)."""
        deliveries: list[Delivery] = []
        for alarm in alarms:
            board = self._whiteboards.get(alarm.whiteboard)
            if board is None:
                continue
            post = Message(
                type=alarm.type,
                sender=alarm.stream,
                to=board.name,
                content=encode_dictionary(Dictionary(entries=alarm.entries)),
                content_is_xml=True,
                language="xml",
            )
            deliveries.extend(self._post(board, post, now_ns, now_ns).deliveries)
        return tuple(deliveries)

    def _no_stream(self, msg: Message, now_ns: int) -> Outcome:
        """Answer a media command: this server offers no streams (OA-GEN-4, OA-STREAM-3)."""
        err = StreamUnknownError(f"no stream named {msg.to!r}")
        return Outcome(replies=(self._error(msg, err, msg.to or "CNS", now_ns),))


def stream_specs(config: ServerConfig, *, typed: bool) -> list[StreamSpec]:
    """Read the configured streams (spec 11.1, 11.7); ConfigError for values that cannot hold."""
    boards = [wb.name for wb in config.whiteboards]
    specs: list[StreamSpec] = []
    types: set[str] = set()
    for wb in config.whiteboards:
        for s in wb.streams:
            try:
                spec = StreamSpec.from_config(s, wb.name, typed_streams=typed, whiteboards=boards)
            except OpenAIRError as err:
                raise ConfigError(
                    f"{config.source or 'psySpec'}: stream {s.name!r}: {err.detail}"
                ) from None
            if spec.type is not None:
                folded = ascii_fold(spec.type)
                if folded in types:  # OA-XSTREAM-1: unique ignoring case
                    raise ConfigError(f"stream {s.name!r}: the type {spec.type!r} is used twice")
                types.add(folded)
            specs.append(spec)
    return specs
