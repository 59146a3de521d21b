"""Raw-socket helpers for the server wire tests: frames in and out, legacy modules, a server thread.

Only `openair.protocol.framing` and `openair.protocol.codec` (plus `xmlsafe` to read content
objects) are used on the wire, never `openair.client`: these tests must see exactly what the server
sends. Every wait is bounded by a deadline (`WAIT`); nothing sleeps to synchronise.
"""

from __future__ import annotations

import contextlib
import queue
import socket
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from lxml import etree
from server_thread import ReferenceServer as ServerThread  # noqa: F401 (re-exported)

from openair.protocol.codec import from_frame, message_from_element, to_frame
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import local_name, parse_fragment

#: The bounded deadline (seconds) for any reply, delivery or close the tests wait for.
WAIT = 15.0
WAKEUP = "AIR.Instruct.Wakeup"


def now() -> AirTime:
    """Return the current time as a poster stamps it (OA-TIME-2)."""
    return AirTime.from_ns(time.time_ns())


def attr(el: etree._Element, name: str) -> str | None:
    """Return attribute `name` of `el`, its name compared case-insensitively (OA-MSG-3)."""
    for key, value in el.attrib.items():
        if str(key).lower() == name.lower():
            return str(value)
    return None


def children(el: etree._Element, name: str) -> list[etree._Element]:
    """Return the child elements of `el` called `name` (any case)."""
    return [c for c in el if isinstance(c.tag, str) and local_name(c) == name.lower()]


def content_elements(msg: Message) -> list[etree._Element]:
    """Return the elements of a message's XML content (text content gives none)."""
    if not msg.content_is_xml or not msg.content.strip():
        return []
    return [e for e in parse_fragment(msg.content) if isinstance(e.tag, str)]


def collection_messages(msg: Message) -> list[Message]:
    """Return the messages of an `<objectcollection>` reply (retrieve results, OA-RET-7)."""
    roots = content_elements(msg)
    assert len(roots) == 1 and local_name(roots[0]) == "objectcollection", msg.content[:300]
    objects = children(roots[0], "object")
    return [message_from_element(m) for obj in objects for m in children(obj, "message")]


@dataclass(frozen=True, slots=True, kw_only=True)
class Delivery:
    """A request the server sent to a module (6.6), as the module received it."""

    module: str
    message: Message
    path: str  # "callback" or "listen"
    trigger: Message | None = None
    retrieved: tuple[Message, ...] = ()
    lasttrigger: str | None = None
    has_phase: bool = False

    @property
    def is_wakeup(self) -> bool:
        """True for a wakeup that carries a trigger message (not a phase update, OA-WAKE-8)."""
        return self.message.type == WAKEUP and self.trigger is not None


def read_delivery(module: str, msg: Message, path: str) -> Delivery:
    """Take a delivered message apart: trigger, retrieved messages and lasttrigger (8.7)."""
    if msg.type != WAKEUP:
        return Delivery(module=module, message=msg, path=path)
    trigger: Message | None = None
    retrieved: list[Message] = []
    lasttrigger: str | None = None
    has_phase = False
    for root in content_elements(msg):
        for obj in children(root, "object"):
            name = attr(obj, "name") or ""
            if name == "TriggerMessage":
                found = children(obj, "message")
                trigger = message_from_element(found[0]) if found else None
            elif name == "RetrievedMessages":
                for coll in children(obj, "objectcollection"):
                    for o in children(coll, "object"):
                        retrieved += [message_from_element(m) for m in children(o, "message")]
            elif name == "PhaseSpec":
                for phase in children(obj, "phase"):
                    has_phase = True
                    lasttrigger = attr(phase, "lasttrigger")
    return Delivery(
        module=module,
        message=msg,
        path=path,
        trigger=trigger,
        retrieved=tuple(retrieved),
        lasttrigger=lasttrigger,
        has_phase=has_phase,
    )


class RawConn:
    """One TCP connection speaking frames, blocking, with bounded waits."""

    def __init__(self, port: int = 0, *, sock: socket.socket | None = None) -> None:
        self.sock = sock if sock is not None else socket.create_connection(("127.0.0.1", port), 10)
        self.reader = FrameReader(FrameLimits())
        self.eof = False
        self._lock = threading.Lock()

    def send_raw(self, data: bytes) -> None:
        """Send bytes as they are."""
        with self._lock:
            self.sock.sendall(data)

    def send_xml(self, xml: bytes, tag: FrameTag = FrameTag.MESSAGE) -> None:
        """Send one frame holding `xml` (no binary chunks)."""
        self.send_raw(encode_frame(Frame(tag=tag, xml=xml)))

    def send(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> None:
        """Send a message in canonical form."""
        self.send_raw(encode_frame(to_frame(msg, tag)))

    def recv_frame(self, timeout: float = WAIT) -> Frame | None:
        """Return the next frame, or None at end of stream; TimeoutError after `timeout`."""
        deadline = time.monotonic() + timeout
        while True:
            frame = self.reader.next_frame()
            if frame is not None:
                return frame
            if self.eof:
                return None
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no frame within the deadline")
            self.sock.settimeout(min(left, 0.5))
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                continue
            except (ConnectionResetError, BrokenPipeError):
                data = b""
            if not data:
                self.eof = True
            else:
                self.reader.feed(data)

    def recv(self, timeout: float = WAIT) -> Message:
        """Return the next message; fail at end of stream."""
        frame = self.recv_frame(timeout)
        assert frame is not None, "the server closed the connection instead of replying"
        return from_frame(frame)

    def request(self, msg: Message) -> Message:
        """Send a request and return its reply, checking `isresponse` (OA-SESS-1)."""
        self.send(msg)
        reply = self.recv()
        assert reply.isresponse == msg.id, (reply.type, reply.isresponse, msg.id)
        return reply

    def frames_until_eof(self, timeout: float = WAIT) -> list[Frame]:
        """Read until the peer closes; return the frames before it (TimeoutError: it never did)."""
        frames: list[Frame] = []
        while (frame := self.recv_frame(timeout)) is not None:
            frames.append(frame)
        return frames

    def close(self) -> None:
        """Close the socket (idempotent)."""
        with contextlib.suppress(OSError):
            self.sock.close()


def answer(module: str, msg: Message) -> Message:
    """Return a legacy module's answer to a delivery (OA-DELIV-4, OA-SESS-11)."""
    kind = {"PING": "PING_SUCCESS", "KEEPALIVE": "KEEPALIVESUCCESS"}.get(msg.type, "RECEIVE_ACCEPT")
    return Message(
        type=kind, sender=module, to=msg.sender, isresponse=msg.id, posted=now(), priority=2.0
    )


class LegacyModule:
    """A module as JavaOpenAIR behaves: answers every delivery on every path, one at a time."""

    def __init__(self, name: str, port: int) -> None:
        self.name = name
        self.port = port
        self.deliveries: queue.Queue[Delivery] = queue.Queue()
        self.errors: list[str] = []
        self.callback: RawConn | None = None
        self.callback_closed = threading.Event()
        self.listener: socket.socket | None = None
        self.listen_port = -1
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._conns: list[RawConn] = []

    def _start(self, target: Any, *args: Any) -> None:
        thread = threading.Thread(target=target, args=args, daemon=True)
        thread.start()
        self._threads.append(thread)

    def adopt_callback(self, conn: RawConn) -> None:
        """Serve `conn` as this module's callback connection (its Receive frame already sent)."""
        self.callback = conn
        self.callback_closed = threading.Event()
        self._start(self._pump, conn, "callback", self.callback_closed)

    def open_callback(self, extensions: str = "") -> RawConn:
        """Open a callback connection: one `Receive` frame, no reply (OA-SESS-7, OA-FRAME-10)."""
        conn = RawConn(self.port)
        msg = Message(
            type="RECEIVE_NAME_NOTIFICATION", sender=self.name, posted=now(), priority=2.0
        )
        if extensions:
            msg = msg.with_extra("extensions", extensions)
        conn.send(msg, FrameTag.RECEIVE)
        self.adopt_callback(conn)
        return conn

    def listen(self, port: int = 0) -> int:
        """Listen for deliveries on `port` (0: any free port); return the port (OA-DELIV-10)."""
        sock = socket.create_server(("127.0.0.1", port))
        if self.listener is not None:
            self.listener.close()
        self.listener = sock
        self.listen_port = int(sock.getsockname()[1])
        self._start(self._accept, sock)
        return self.listen_port

    def _accept(self, sock: socket.socket) -> None:
        sock.settimeout(0.5)
        while not self._stop.is_set():
            try:
                client, _ = sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            self._start(self._pump, RawConn(sock=client), "listen", threading.Event())

    def _pump(self, conn: RawConn, path: str, closed: threading.Event) -> None:
        self._conns.append(conn)
        try:
            while not self._stop.is_set():
                try:
                    frame = conn.recv_frame(timeout=0.5)
                except TimeoutError:
                    continue
                if frame is None:
                    break
                msg = from_frame(frame)
                conn.send(answer(self.name, msg))
                self.deliveries.put(read_delivery(self.name, msg, path))
        except Exception as exc:  # a broken delivery is a finding, reported by the test
            if not self._stop.is_set():
                self.errors.append(f"{path}: {type(exc).__name__}: {exc}")
        finally:
            closed.set()
            conn.close()

    def take(self, timeout: float = WAIT) -> Delivery:
        """Return the next delivery (TimeoutError when none arrives in time)."""
        try:
            return self.deliveries.get(timeout=timeout)
        except queue.Empty:
            raise TimeoutError(f"{self.name}: no delivery within {timeout} s") from None

    def drain(self) -> Iterator[Delivery]:
        """Yield the deliveries already received, without waiting."""
        while True:
            try:
                yield self.deliveries.get_nowait()
            except queue.Empty:
                return

    def close(self) -> None:
        """Stop every thread and close every socket of this module."""
        self._stop.set()
        if self.listener is not None:
            self.listener.close()
        for conn in list(self._conns):
            conn.close()
        if self.callback is not None:
            self.callback.close()
        for thread in self._threads:
            thread.join(timeout=5)
