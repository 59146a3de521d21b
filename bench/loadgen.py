"""A load generator for whiteboard servers that is not the bottleneck (used by bench_server).

Posters and subscribers run in their own processes and speak raw frames: posts are encoded once
and only their sequence number and send time change (a fixed-width field patched in place), and
subscribers find a frame's length in its 12-byte header and its id with one `bytes.find`, so
neither side parses XML. A subscriber acknowledges every delivery (OA-DELIV-4) and declares
`pipelining` so the server may keep several deliveries in flight (OA-DELIV-5).

Results travel back through `multiprocessing` shared values and a queue: counts, and for latency
runs the (send ns, receive ns) pairs of every delivered post.
"""

from __future__ import annotations

import os
import socket
import struct
import time
import uuid
from dataclasses import dataclass
from multiprocessing.sharedctypes import Synchronized

_HEADER = struct.Struct("<7sxI")
SEQ_WIDTH = 32  # "<seq>:<send_ns>" is padded to this width so posts keep one length
_MARK = b"@@SEQ@@"


def frame(xml: bytes, tag: bytes = b"Message") -> bytes:
    """Frame one XML message (OA-FRAME-1)."""
    return _HEADER.pack(tag, len(xml)) + xml


def message(
    type_: str,
    *,
    sender: str = "",
    to: str = "",
    content: str = "",
    xml_content: bool = False,
    extra: str = "",
    noreply: bool = False,
    msg_id: str | None = None,
) -> bytes:
    """Build the canonical XML of a message as bytes (no clock read: postedTime is fixed)."""
    lang = "xml" if xml_content else ""
    attrs = ' priority="2.0"' + (' noreply="yes"' if noreply else "")
    return (
        f"<message{attrs}><type>{type_}</type><id>{msg_id or uuid.uuid4()}</id>"
        f"<from>{sender}</from><to>{to}</to><cc></cc><stored></stored><isresponse></isresponse>"
        f'<postedTime sec="0" msec="0"/><content language="{lang}">{content}</content>{extra}'
        "</message>"
    ).encode()


def read_frames(sock: socket.socket, buf: bytearray) -> list[bytes]:
    """Read what is available and return the complete frame bodies (XML) in `buf`."""
    data = sock.recv(1 << 20)
    if not data:
        raise ConnectionError("closed")
    buf += data
    out: list[bytes] = []
    pos = 0
    while len(buf) - pos >= 12:
        _, length = _HEADER.unpack_from(buf, pos)
        if len(buf) - pos - 12 < length:
            break
        out.append(bytes(buf[pos + 12 : pos + 12 + length]))
        pos += 12 + length
    del buf[:pos]
    return out


def first_text(xml: bytes, tag: bytes) -> bytes:
    """Return the text of the first `<tag>` element in `xml` (plain search, no parsing)."""
    start = xml.find(b"<" + tag + b">")
    if start < 0:
        return b""
    start += len(tag) + 2
    return xml[start : xml.find(b"</", start)]


def request(sock: socket.socket, buf: bytearray, xml: bytes, tag: bytes = b"Message") -> bytes:
    """Send one request and return the XML of the next frame (its reply)."""
    sock.sendall(frame(xml, tag))
    while True:
        frames = read_frames(sock, buf)
        if frames:
            if len(frames) > 1:
                raise RuntimeError("unexpected extra frames during setup")
            return frames[0]


def connect(port: int) -> socket.socket:
    """Connect to the server on loopback with Nagle off."""
    sock = socket.create_connection(("127.0.0.1", port))
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


@dataclass(frozen=True, slots=True, kw_only=True)
class SubscriberSpec:
    """What one subscriber process does."""

    port: int
    name: str
    patterns: tuple[str, ...]
    expected: int  # deliveries of bench posts to wait for
    relay: bool = False  # the minimal relay speaks no session: just read frames


def _setup_module(spec: SubscriberSpec) -> tuple[socket.socket, socket.socket]:
    """BIND_NOLISTEN, open the callback connection, subscribe; return (primary, callback)."""
    primary, buf = connect(spec.port), bytearray()
    ext = "<extensions>pipelining</extensions>"
    reply = request(primary, buf, message("BIND_NOLISTEN", sender=spec.name, to="CNS", extra=ext))
    if first_text(reply, b"type") != b"BIND_ACCEPT":
        raise RuntimeError(f"BIND refused: {reply[:200]!r}")
    callback = connect(spec.port)
    note = message("RECEIVE_NAME_NOTIFICATION", sender=spec.name, extra=ext)
    callback.sendall(frame(note, b"Receive"))
    triggers = "".join(f'<trigger type="{p}" from="any"/>' for p in spec.patterns)
    sub = message(
        "AIR.Subscribe",
        sender=spec.name,
        to="AIRCentral",
        content=f'<module name="{spec.name}">{triggers}</module>',
        xml_content=True,
    )
    reply = request(primary, buf, sub)
    if first_text(reply, b"type") != b"RECEIVE_ACCEPT":
        raise RuntimeError(f"AIR.Subscribe refused: {reply[:300]!r}")
    return primary, callback


def _ack(xml: bytes, name: str) -> bytes:
    rid = first_text(xml, b"id").decode()
    return frame(
        b"<message><type>RECEIVE_ACCEPT</type><id>"
        + str(uuid.uuid4()).encode()
        + f"</id><from>{name}</from><to></to><cc></cc><stored></stored><isresponse>".encode()
        + rid.encode()
        + b'</isresponse><postedTime sec="0" msec="0"/><content language=""/></message>'
    )


def subscriber(
    spec: SubscriberSpec,
    ready: Synchronized[int],
    received: Synchronized[int],
    samples: list[tuple[int, int]] | None,
    out: object,
) -> None:
    """Receive `spec.expected` bench deliveries, acknowledging each; report latencies to `out`."""
    if spec.relay:
        callback = connect(spec.port)
        callback.sendall(frame(message("SUBSCRIBE", sender=spec.name), b"Receive"))
        primary = None
    else:
        primary, callback = _setup_module(spec)
    with ready.get_lock():
        ready.value += 1
    buf, got, lat = bytearray(), 0, []
    while got < spec.expected:
        frames = read_frames(callback, buf)
        now = time.time_ns()
        acks = []
        for xml in frames:
            if not spec.relay:
                acks.append(_ack(xml, spec.name))
            pos = xml.find(_MARK)
            if pos < 0:
                continue  # a phase update or another notice
            field = xml[pos + len(_MARK) : pos + len(_MARK) + SEQ_WIDTH].split(b":")
            lat.append((int(field[0]), now - int(field[1].rstrip(b"_"))))
            got += 1
        if acks:
            callback.sendall(b"".join(acks))
        with received.get_lock():
            received.value += len(frames)
    if hasattr(out, "put"):
        out.put((spec.name, lat))
    callback.close()
    if primary is not None:
        primary.close()


@dataclass(frozen=True, slots=True, kw_only=True)
class PosterSpec:
    """What the poster process sends."""

    port: int
    count: int
    type_: str
    whiteboard: str = "WB1"
    rate: float | None = None  # posts per second; None = as fast as the window allows
    window: int = 2000  # at most this many posts ahead of the slowest subscriber
    fanout: int = 1
    size: int = 256


def _post_template(spec: PosterSpec) -> tuple[bytes, int]:
    """Return a framed noreply post padded to about `spec.size` bytes and the seq offset."""
    base = message(spec.type_, sender="BenchPoster", to=spec.whiteboard, content="", noreply=True)
    pad = max(0, spec.size - len(base) - len(_MARK) - SEQ_WIDTH)
    content = _MARK.decode() + "0" * SEQ_WIDTH + "x" * pad
    xml = message(
        spec.type_,
        sender="BenchPoster",
        to=spec.whiteboard,
        content=content,
        noreply=True,
        msg_id="00000000-0000-4000-8000-000000000000",
    )
    framed = frame(xml)
    return framed, framed.find(_MARK) + len(_MARK)


def poster(spec: PosterSpec, received: Synchronized[int], start_ns: Synchronized[int]) -> None:
    """Send `spec.count` noreply posts, paced by `rate` or by the delivery window."""
    sock = connect(spec.port)
    template, offset = _post_template(spec)
    buf = bytearray(template)
    start = time.perf_counter()
    start_ns.value = time.time_ns()
    batch = 1 if spec.rate else 64
    sent = 0
    while sent < spec.count:
        if spec.rate:
            due = start + sent / spec.rate
            while (delay := due - time.perf_counter()) > 0:
                time.sleep(min(delay, 0.0005))
        else:
            while sent - received.value // spec.fanout > spec.window:
                time.sleep(0.0002)
        chunk = bytearray()
        for _ in range(min(batch, spec.count - sent)):
            field = f"{sent}:{time.time_ns()}".encode().ljust(SEQ_WIDTH, b"_")
            assert len(field) == SEQ_WIDTH  # the frame's length header must stay true
            buf[offset : offset + SEQ_WIDTH] = field
            chunk += buf
            sent += 1
        sock.sendall(chunk)
    # a final PING proves the server has read everything (it answers in order, OA-SESS-2)
    pong = request(sock, bytearray(), message("PING", sender="BenchPoster", to="CNS"))
    if first_text(pong, b"type") != b"PING_SUCCESS":
        raise RuntimeError(f"PING answered {pong[:200]!r}")
    sock.close()


def pin(cpu: int) -> None:
    """Pin the calling process to one CPU when the machine has it (best effort)."""
    if hasattr(os, "sched_setaffinity") and cpu < (os.cpu_count() or 1):
        os.sched_setaffinity(0, {cpu})
