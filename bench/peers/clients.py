"""Per-protocol connection setup, publish templates and round trips for the load generator.

Protocols: "openair" (the reference server: BIND_NOLISTEN + callback + AIR.Subscribe, acked
deliveries, `noreply` posts), "relay" (bench.relay: framed, no session), "mqtt" (mosquitto,
amqtt), "nats" and "redis". Patterns are given in each system's own wildcard syntax by
`flow_pattern` and `idle_pattern`; every bench message goes to the topic of `flow_topic`.
"""

from __future__ import annotations

import socket
import time

from bench.loadgen import connect, first_text, frame, message, read_frames, request
from bench.peers import protocols as p

_FLOW = {
    "openair": ("Bench.Flow.Data", "Bench.Flow.*"),
    "relay": ("Bench.Flow.Data", "Bench.Flow.*"),
    "mqtt": ("bench/flow/data", "bench/flow/#"),
    "nats": ("bench.flow.data", "bench.flow.>"),
    "redis": ("bench.flow.data", "bench.flow.*"),
}
_IDLE = {
    "openair": "Bench.Idle{}.*",
    "relay": "Bench.Idle{}.*",
    "mqtt": "bench/idle{}/#",
    "nats": "bench.idle{}.>",
    "redis": "bench.idle{}.*",
}
SETUP_TIMEOUT = 120.0  # subscribing 10 000 patterns on the slowest broker


def flow_topic(proto: str) -> str:
    return _FLOW[proto][0]


def flow_pattern(proto: str) -> str:
    return _FLOW[proto][1]


def idle_pattern(proto: str, i: int) -> str:
    """Return the i-th pattern that never matches a bench message, in the protocol's syntax."""
    return _IDLE[proto].format(i)


def _recv_until(sock: socket.socket, done: bytes) -> bytes:
    """Read until `done` occurs in what was read; return everything read."""
    data = bytearray()
    deadline = time.monotonic() + SETUP_TIMEOUT
    while True:
        if time.monotonic() > deadline:
            raise TimeoutError(f"no {done!r} within {SETUP_TIMEOUT} s")
        chunk = sock.recv(1 << 20)
        if not chunk:
            raise ConnectionError("closed during setup")
        data += chunk
        if done in data[max(0, len(data) - len(chunk) - len(done)) :]:
            return bytes(data)


# --- subscribers --------------------------------------------------------------------------------


def open_subscriber(proto: str, port: int, name: str, patterns: list[str]) -> list[socket.socket]:
    """Connect and subscribe to `patterns`; return the sockets, the delivering one first."""
    if proto == "openair":
        return _openair_subscriber(port, name, patterns)
    sock = connect(port)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    if proto == "relay":
        sock.sendall(frame(message("SUBSCRIBE", sender=name), b"Receive"))
    elif proto == "mqtt":
        _mqtt_subscribe(sock, name, patterns)
    elif proto == "nats":
        _recv_until(sock, b"\r\n")  # INFO
        subs = b"".join(p.nats_sub(pat, i + 1) for i, pat in enumerate(patterns))
        sock.sendall(p.nats_connect() + subs + p.NATS_PING)
        _recv_until(sock, p.NATS_PONG)
    elif proto == "redis":
        _redis_subscribe(sock, patterns)
    else:
        raise ValueError(f"unknown protocol {proto!r}")
    return [sock]


def _mqtt_subscribe(sock: socket.socket, name: str, patterns: list[str]) -> None:
    sock.sendall(p.mqtt_connect(name))
    _mqtt_expect(sock, p.MQTT_CONNACK, 1)
    batches = [patterns[i : i + 200] for i in range(0, len(patterns), 200)]
    sock.sendall(b"".join(p.mqtt_subscribe(i + 1, b) for i, b in enumerate(batches)))
    _mqtt_expect(sock, p.MQTT_SUBACK, len(batches))


def _mqtt_expect(sock: socket.socket, kind: int, count: int) -> None:
    buf, seen = bytearray(), 0
    deadline = time.monotonic() + SETUP_TIMEOUT
    while seen < count:
        if time.monotonic() > deadline:
            raise TimeoutError(f"MQTT: {seen}/{count} packets of type {kind}")
        chunk = sock.recv(1 << 16)
        if not chunk:
            raise ConnectionError("MQTT broker closed during setup")
        buf += chunk
        packets, used = p.mqtt_split(bytes(buf))
        del buf[:used]
        for ptype, body in packets:
            if ptype == p.MQTT_CONNACK and body[1:2] != b"\x00":
                raise RuntimeError(f"CONNACK refused: {body!r}")
            if ptype == p.MQTT_SUBACK and b"\x80" in body[2:]:
                raise RuntimeError("SUBACK refused a filter")
            seen += ptype == kind


def _redis_subscribe(sock: socket.socket, patterns: list[str]) -> None:
    batches = [patterns[i : i + 500] for i in range(0, len(patterns), 500)]
    sock.sendall(b"".join(p.resp_command("PSUBSCRIBE", *b) for b in batches))
    buf, seen = bytearray(), 0
    deadline = time.monotonic() + SETUP_TIMEOUT
    while seen < len(patterns):
        if time.monotonic() > deadline:
            raise TimeoutError(f"redis: {seen}/{len(patterns)} PSUBSCRIBE confirmations")
        chunk = sock.recv(1 << 20)
        if not chunk:
            raise ConnectionError("redis closed during setup")
        buf += chunk
        values, used = p.resp_parse_all(bytes(buf))
        del buf[:used]
        for value in values:
            if isinstance(value, p.RespError):
                raise RuntimeError(f"redis: {value}")
            seen += 1


def _openair_subscriber(port: int, name: str, patterns: list[str]) -> list[socket.socket]:
    """BIND_NOLISTEN, open the callback connection, subscribe (≤ 1 000 triggers per request)."""
    primary, buf = connect(port), bytearray()
    ext = "<extensions>pipelining</extensions>"
    reply = request(primary, buf, message("BIND_NOLISTEN", sender=name, to="CNS", extra=ext))
    if first_text(reply, b"type") != b"BIND_ACCEPT":
        raise RuntimeError(f"BIND refused: {reply[:200]!r}")
    callback = connect(port)
    callback.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    note = message("RECEIVE_NAME_NOTIFICATION", sender=name, extra=ext)
    callback.sendall(frame(note, b"Receive"))
    for start in range(0, len(patterns), 1000):
        chunk = patterns[start : start + 1000]
        triggers = "".join(f'<trigger type="{t}" from="any"/>' for t in chunk)
        sub = message(
            "AIR.Subscribe",
            sender=name,
            to="AIRCentral",
            xml_content=True,
            content=f'<module name="{name}">{triggers}</module>',
        )
        reply = request(primary, buf, sub)
        if first_text(reply, b"type") != b"RECEIVE_ACCEPT":
            raise RuntimeError(f"AIR.Subscribe refused: {reply[:300]!r}")
    return [callback, primary]


_ACK_HEAD = b"<message><type>RECEIVE_ACCEPT</type><id>"
_ACK_TAIL = b'</isresponse><postedTime sec="0" msec="0"/><content language=""/></message>'


def openair_acks(frames: list[bytes], name: str, counter: int) -> bytes:
    """Return one RECEIVE_ACCEPT frame per delivered frame (OA-DELIV-4), ids from `counter`."""
    middle = f"</id><from>{name}</from><to></to><cc></cc><stored></stored><isresponse>".encode()
    out = []
    for i, xml in enumerate(frames):
        body = _ACK_HEAD + b"a%d" % (counter + i) + middle + first_text(xml, b"id") + _ACK_TAIL
        out.append(frame(body))
    return b"".join(out)


def take_frames(sock: socket.socket, buf: bytearray) -> list[bytes]:
    """Read once and return the complete OpenAIR frames (bodies)."""
    return read_frames(sock, buf)


# --- publishers ---------------------------------------------------------------------------------


def open_publisher(proto: str, port: int) -> socket.socket:
    """Connect a publisher and finish its handshake."""
    sock = connect(port)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
    if proto == "mqtt":
        sock.sendall(p.mqtt_connect(f"bench-pub-{time.time_ns()}"))
        _mqtt_expect(sock, p.MQTT_CONNACK, 1)
    elif proto == "nats":
        _recv_until(sock, b"\r\n")
        sock.sendall(p.nats_connect() + p.NATS_PING)
        _recv_until(sock, p.NATS_PONG)
    return sock


def template(proto: str, size: int) -> tuple[bytes, int]:
    """Return one encoded publish of a `size`-byte payload and the offset of its stamp field."""
    data, at = p.payload(size)
    topic = flow_topic(proto)
    if proto in ("openair", "relay"):
        xml = message(
            topic,
            sender="BenchPoster",
            to="WB1",
            content=data.decode(),
            noreply=True,
            msg_id="00000000-0000-4000-8000-000000000000",
        )
        encoded = frame(xml)
    elif proto == "mqtt":
        encoded = p.mqtt_publish(topic, data)
    elif proto == "nats":
        encoded = p.nats_pub(topic, data)
    else:
        encoded = p.resp_command("PUBLISH", topic, data)
    return encoded, encoded.find(p.MARK) + at


def ping(proto: str) -> tuple[bytes, bytes]:
    """Return (request, what the reply contains) for a round trip that follows every publish."""
    if proto in ("openair", "relay"):
        return frame(message("PING", sender="BenchPoster", to="CNS")), b"PING_SUCCESS"
    if proto == "mqtt":
        return p.MQTT_PINGREQ, b"\xd0\x00"
    if proto == "nats":
        return p.NATS_PING, p.NATS_PONG
    return p.resp_command("PING"), b"+PONG\r\n"


def round_trip(proto: str, sock: socket.socket) -> None:
    """Send a ping and wait for its answer: the broker has then read every earlier publish."""
    req, done = ping(proto)
    sock.setblocking(True)
    sock.sendall(req)
    _recv_until(sock, done)
