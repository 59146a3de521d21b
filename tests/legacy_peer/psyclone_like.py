"""A scripted legacy peer: the reference server made to look like Psyclone 1.1.7 on the wire.

Test support for the conformance harness (issue #16). The reference server's router decides
everything; this module changes only what goes on the wire, as the frames of the second
observation campaign show (/work/shared/reference/psyclone-observed-2.md, copied here as
behaviour, never read at run time):

- `decimals`: priorities written with two decimals (`priority="7.00"` for a posted 6.999, §1a),
  0 written as no attribute;
- `indent`: multi-line XML, a newline and a tab before every slot, and
  `<postedTime  sec=".." msec=".." tzc=".."/>` with two spaces (every quote in §1-§12);
- `module_identity`: `<module name="x">` in an AIR.Subscribe registers the module `x`, not the
  sender (§5);
- `stream_ports`: RESOLVE_REQUEST of a stream gives the stream's own port, and stream commands
  sent to the main port are answered LOC_INVALID with an empty `from` and `to` = CNS (§9);
- `pace_s`: every frame the peer writes leaves about that long after it was due (a slow
  target: replies and deliveries alike, in order);
- `die_after_connections` / `die_at`: the peer dies (listener and every connection gone) when a
  connection beyond that count arrives, or when a frame names a token (a case's ID token such as
  `WB005` appears in its sender or type) — as Psyclone did during WB-005 and SESS-013 (§8).

It is legacy: GET_CAPABILITIES is UNKNOWN_COMMAND (OA-CAP-2), no extension is advertised.
Run it as a program for restart tests: `python psyclone_like.py --port P [flags]`.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import contextlib
import os
import re
import signal
import sys
from dataclasses import dataclass, replace
from typing import Any

from lxml import etree

from openair.protocol.codec import to_frame
from openair.protocol.errors import ApiMisuseError
from openair.protocol.framing import Frame, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.aio.app import Server, ServerOptions
from openair.server.aio.protocol import Role, ServerConnection
from openair.server.aio.stores import open_store
from openair.server.core.config import default_config
from openair.server.core.router import Outcome

__all__ = ["LegacyOptions", "LegacyServer", "legacy_xml", "start_legacy"]

_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
_STREAM_COMMANDS = re.compile(
    r"^(ADD_SAMPLE|WAIT_FOR_|GET_|PING$|RECEIVE_NAME_NOTIFICATION$)", re.IGNORECASE
)
_INDENTED = frozenset({"message", "objectdictionary", "objectcollection", "object"})
_TIMES = re.compile(rb"<(postedTime|receivedTime) ")


@dataclass(frozen=True, slots=True, kw_only=True)
class LegacyOptions:
    """What the peer does like Psyclone; each test turns on what it needs."""

    decimals: bool = True
    #: How a priority is written when `decimals` (Psyclone: two decimals, 6.999 → "7.00").
    priority_format: str = "{:.2f}"
    indent: bool = True
    module_identity: bool = True
    stream_ports: bool = True
    pace_s: float = 0.0
    die_after_connections: int | None = None
    die_at: str | None = None


def _local(el: Any) -> str:
    return etree.QName(el).localname.lower() if isinstance(el.tag, str) else ""


def legacy_xml(xml: bytes, options: LegacyOptions) -> bytes:
    """Rewrite a message's XML as Psyclone writes it (priorities, indentation, times)."""
    if not (options.decimals or options.indent):
        return xml
    root = etree.fromstring(xml, _PARSER)
    for el in root.iter():
        name = _local(el)
        if name == "message" and options.decimals and "priority" in el.attrib:
            value = float(el.attrib["priority"])
            if value == 0:
                del el.attrib["priority"]
            else:
                el.attrib["priority"] = options.priority_format.format(value)
        if name in ("postedtime", "receivedtime") and options.indent:
            el.attrib["tzc"] = "Greenwich_0_60"
        if name in _INDENTED and options.indent and len(el) and not (el.text or "").strip():
            el.text = "\n\t"
            for child in el:
                if not (child.tail or "").strip():
                    child.tail = "\n\t"
            el[-1].tail = "\n"
    out = etree.tostring(root, encoding="utf-8")
    return _TIMES.sub(rb"<\1  ", out) if options.indent else out


class _PacedTransport(asyncio.Transport):
    """A transport whose writes leave `delay` seconds late, in order (a slow legacy target)."""

    def __init__(self, inner: asyncio.Transport, delay: float) -> None:
        super().__init__()
        self._inner = inner
        self._delay = delay
        self._queue: collections.deque[tuple[float, bytes]] = collections.deque()
        self._timer: asyncio.TimerHandle | None = None
        self._close_after = False
        self._eof_after = False

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def write(self, data: bytes | bytearray | memoryview) -> None:
        loop = asyncio.get_running_loop()
        self._queue.append((loop.time() + self._delay, bytes(data)))
        if self._timer is None:
            self._timer = loop.call_at(self._queue[0][0], self._release)

    def get_write_buffer_size(self) -> int:
        return int(self._inner.get_write_buffer_size())

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return self._inner.get_extra_info(name, default)

    def set_write_buffer_limits(self, high: int | None = None, low: int | None = None) -> None:
        self._inner.set_write_buffer_limits(high, low)

    def pause_reading(self) -> None:
        self._inner.pause_reading()

    def resume_reading(self) -> None:
        self._inner.resume_reading()

    def is_closing(self) -> bool:
        return self._inner.is_closing()

    def can_write_eof(self) -> bool:
        return self._inner.can_write_eof()

    def write_eof(self) -> None:
        if self._queue:
            self._eof_after = True  # after what was written
        else:
            self._inner.write_eof()

    def _release(self) -> None:
        self._timer = None
        loop = asyncio.get_running_loop()
        while self._queue and self._queue[0][0] <= loop.time() + 0.001:
            if not self._inner.is_closing():
                self._inner.write(self._queue.popleft()[1])
            else:
                self._queue.clear()
        if self._queue:
            self._timer = loop.call_at(self._queue[0][0], self._release)
            return
        if self._eof_after and not self._inner.is_closing():
            self._eof_after = False
            self._inner.write_eof()
        if self._close_after:
            self._inner.close()

    def close(self) -> None:
        if self._queue:
            self._close_after = True  # what was written goes out first, as with a real close
        else:
            self._inner.close()

    def crash(self) -> None:
        """Vanish with what was not sent yet (a crashed process sends nothing more)."""
        self._queue.clear()
        if self._timer is not None:
            self._timer.cancel()
        self._inner.abort()

    def abort(self) -> None:
        # A real transport has usually sent what was written before an abort: so does this.
        while self._queue and not self._inner.is_closing():
            self._inner.write(self._queue.popleft()[1])
        self._queue.clear()
        if self._timer is not None:
            self._timer.cancel()
        self._inner.abort()


class LegacyConnection(ServerConnection):
    """A server connection that writes Psyclone's XML and can be slow."""

    host: LegacyServer

    def __init__(
        self, host: LegacyServer, role: Role = Role.RESPONDER, *, stream: str = ""
    ) -> None:
        super().__init__(host, role)
        self.stream_port_of = stream  # the stream whose own port this connection came to

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        pace = self.host.legacy.pace_s
        if pace > 0 and isinstance(transport, asyncio.Transport):
            transport = _PacedTransport(transport, pace)
        super().connection_made(transport)

    def send(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE, wire: Any = None) -> bool:
        return super().send(msg, tag, None)  # always re-encode: the legacy form

    def encode(self, msg: Message, tag: FrameTag) -> tuple[bytes, ...]:
        if tag is FrameTag.BINARY:
            return super().encode(msg, tag)
        try:
            frame = to_frame(msg, tag)
        except ApiMisuseError:
            return super().encode(msg, tag)  # its RECEIVE_ERROR
        xml = legacy_xml(frame.xml, self.host.legacy)
        return (encode_frame(Frame(tag=tag, xml=xml, chunks=frame.chunks)),)


class LegacyServer(Server):
    """The reference server behind Psyclone's wire habits (see the module docstring)."""

    legacy: LegacyOptions
    sends_frames = False  # every reply is re-encoded in the legacy form from its text

    def _protocol(self) -> ServerConnection:
        return LegacyConnection(self, Role.RESPONDER)

    async def connect(self, module: str, address: str, port: int) -> ServerConnection:
        loop = asyncio.get_running_loop()
        _, conn = await loop.create_connection(
            lambda: LegacyConnection(self, Role.OUTBOUND), address, port
        )
        conn.module = module
        self._outbound.add(conn)
        conn.closed.add_done_callback(lambda _: self._outbound.discard(conn))
        return conn

    def setup_legacy(self, legacy: LegacyOptions) -> None:
        """Remember the options; called once before serving."""
        self.legacy = legacy
        self.connections_seen = 0
        self.dead = asyncio.get_running_loop().create_future()
        self._stream_listeners: dict[str, asyncio.Server] = {}
        self._stream_ports: dict[str, int] = {}

    def connection_opened(self, conn: ServerConnection) -> int:
        self.connections_seen += 1
        limit = self.legacy.die_after_connections
        if limit is not None and self.connections_seen > limit:
            self.die(f"connection {self.connections_seen} (limit {limit})")
        return super().connection_opened(conn)

    def handle(
        self, conn: ServerConnection, msg: Message, *, tag: FrameTag, received_ns: int
    ) -> Outcome:
        token = self.legacy.die_at
        if token and (token in msg.sender or token in msg.type):
            self.die(f"a frame of {token}")
            return Outcome()
        if msg.type == "GET_CAPABILITIES" and msg.to in ("", "CNS"):  # legacy (OA-CAP-2)
            reply = Message(
                type="UNKNOWN_COMMAND",
                sender="CNS",
                to=msg.sender,
                isresponse=msg.id,
                content=f"Offending cmd: {msg.type}",
            )
            return Outcome(replies=(reply,))
        if self.legacy.stream_ports and self._stream_on_main_port(conn, msg):
            return self._reply_only(conn, msg, "LOC_INVALID", sender="", to="CNS")
        if self.legacy.module_identity and msg.type == "AIR.Subscribe":
            msg = _as_named_module(msg)
        outcome = super().handle(conn, msg, tag=tag, received_ns=received_ns)
        if self.legacy.stream_ports and msg.type == "RESOLVE_REQUEST":
            return self._own_stream_port(outcome, msg.content.strip())
        return outcome

    def _stream_on_main_port(self, conn: ServerConnection, msg: Message) -> bool:
        on_main = not getattr(conn, "stream_port_of", "")
        is_stream = bool(msg.to) and self.router.streams.resolve(msg.to) is not None
        return on_main and is_stream and bool(_STREAM_COMMANDS.match(msg.type))

    def _reply_only(
        self, conn: ServerConnection, msg: Message, kind: str, *, sender: str, to: str
    ) -> Outcome:
        reply = Message(type=kind, sender=sender, to=to, isresponse=msg.id)
        return Outcome(replies=(reply,))

    def _own_stream_port(self, outcome: Outcome, name: str) -> Outcome:
        """Give a stream its own port on RESOLVE_SUCCESS (Psyclone's 20111 for Stream1)."""
        port = self._stream_ports.get(name)
        if port is None or not outcome.replies or outcome.replies[0].type != "RESOLVE_SUCCESS":
            return outcome
        reply = outcome.replies[0]
        content = re.sub(r'port="\d+"', f'port="{port}"', reply.content, count=1)
        return replace(outcome, replies=(replace(reply, content=content), *outcome.replies[1:]))

    async def open_stream_ports(self) -> None:
        """Listen on a port of its own for each configured stream."""
        for name in self.router.streams.names():
            listener = await asyncio.get_running_loop().create_server(
                lambda n=name: LegacyConnection(self, Role.RESPONDER, stream=n),  # type: ignore[misc]
                self.host,
                0,
            )
            self._stream_listeners[name] = listener
            self._stream_ports[name] = int(listener.sockets[0].getsockname()[1])

    def die(self, why: str) -> None:
        """Vanish as a crashed process does: no listener, every connection reset."""
        if self.dead.done():
            return
        self.dead.set_result(why)
        self._final = True  # no more deliveries; stop() still closes what is left
        if self._listener is not None:
            self._listener.close()
        for listener in self._stream_listeners.values():
            listener.close()
        for conn in [*self._conns.values(), *self._outbound]:
            if isinstance(conn.transport, _PacedTransport):
                conn.transport.crash()
            conn.abort()


def _as_named_module(msg: Message) -> Message:
    """Take `<module name="x">` as the identity of the module registered (observed §5)."""
    try:
        root = etree.fromstring(f"<c>{msg.content}</c>".encode(), _PARSER)
    except etree.XMLSyntaxError:
        return msg
    first = next((el for el in root if isinstance(el.tag, str)), None)
    if first is None or _local(first) != "module":
        return msg
    name = first.attrib.get("name", "")
    return replace(msg, sender=str(name)) if name else msg


async def start_legacy(
    legacy: LegacyOptions | None = None, *, host: str = "127.0.0.1", port: int = 0
) -> LegacyServer:
    """Start a scripted legacy peer and return it listening (port 0 picks one)."""
    options = ServerOptions(host=host, port=port, extensions=frozenset(), monitor=False)
    server = LegacyServer(options, default_config(), open_store("memory"))
    server.setup_legacy(legacy or LegacyOptions())
    await server._listen()
    if server.legacy.stream_ports:
        await server.open_stream_ports()
    return server


def _parse(argv: list[str]) -> tuple[LegacyOptions, int, str]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--pace", type=float, default=0.0)
    parser.add_argument("--die-after-connections", type=int)
    parser.add_argument("--die-at")
    parser.add_argument("--pidfile", default="")
    parser.add_argument("--plain", action="store_true", help="no decimals, no indentation")
    args = parser.parse_args(argv)
    legacy = LegacyOptions(
        decimals=not args.plain,
        indent=not args.plain,
        pace_s=args.pace,
        die_after_connections=args.die_after_connections,
        die_at=args.die_at,
    )
    return legacy, args.port, args.pidfile


async def _main(argv: list[str]) -> int:
    legacy, port, pidfile = _parse(argv)
    server = await start_legacy(legacy, port=port)
    if pidfile:
        with open(pidfile, "w", encoding="ascii") as handle:
            handle.write(f"{os.getpid()}\n")
    print(f"listening on 127.0.0.1:{server.port}", flush=True)
    stop = asyncio.get_running_loop().create_future()
    asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, stop.set_result, None)
    await asyncio.wait({stop, server.dead}, return_when=asyncio.FIRST_COMPLETED)
    if not server.dead.done():
        with contextlib.suppress(Exception):
            await asyncio.wait_for(server.stop(), 5.0)
    return 0


if __name__ == "__main__":
    sys.exit(asyncio.run(_main(sys.argv[1:])))
