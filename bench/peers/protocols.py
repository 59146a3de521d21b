"""Hand-rolled wire encoders and decoders for the peers: MQTT 3.1.1, NATS text, RESP, and stamps.

Only what the benchmark needs: MQTT CONNECT / SUBSCRIBE / PUBLISH (QoS 0) / PINGREQ and a packet
splitter; NATS CONNECT / SUB / PUB / PING and a parser for what the server sends (INFO, MSG, PING,
PONG, +OK, -ERR); RESP commands and a reply parser. Decoders are incremental: they take a buffer
and return the complete items plus how many bytes they consumed, and raise `ValueError` on bytes
that cannot be the protocol (a bench tool, so no OpenAIR error codes).

A *stamp* is the fixed-width field every bench message carries in its payload: a marker, then
"<seq>:<send ns>" padded with "_", so a template can be patched in place without changing any
length field. Subscribers find stamps with `bytes.find` and never parse the protocol on the hot
path (`scan_stamps`).
"""

from __future__ import annotations

import struct

MARK = b"@@SEQ@@"
STAMP_WIDTH = 32
STAMP_LEN = len(MARK) + STAMP_WIDTH


# --- stamps -------------------------------------------------------------------------------------


def stamp(seq: int, send_ns: int) -> bytes:
    """Return the fixed-width field "<seq>:<send_ns>" padded with "_" (no marker)."""
    field = f"{seq}:{send_ns}".encode()
    if len(field) > STAMP_WIDTH:
        raise ValueError(f"stamp too long: {field!r}")
    return field.ljust(STAMP_WIDTH, b"_")


def payload(size: int) -> tuple[bytes, int]:
    """Return a payload of `size` bytes (at least a stamp) and the offset of its stamp field."""
    if size < STAMP_LEN:
        raise ValueError(f"payload must hold a stamp ({STAMP_LEN} bytes)")
    return MARK + b"0" * STAMP_WIDTH + b"x" * (size - STAMP_LEN), len(MARK)


def scan_stamps(buf: bytes, out: list[tuple[int, int]]) -> bytes:
    """Append (seq, send_ns) for every complete stamp in `buf` to `out`; return the unread tail.

    The tail is what may hold the start of a stamp split across reads: prepend it to the next
    read. Bytes between stamps are ignored, so any protocol's framing can be scanned as is.
    """
    pos = 0
    end = len(buf)
    find = buf.find
    while True:
        at = find(MARK, pos)
        if at < 0:
            return buf[max(pos, end - len(MARK) + 1) :]
        if at + STAMP_LEN > end:
            return buf[at:]
        seq, _, ns = buf[at + len(MARK) : at + STAMP_LEN].partition(b":")
        out.append((int(seq), int(ns.rstrip(b"_"))))
        pos = at + STAMP_LEN


# --- MQTT 3.1.1 ---------------------------------------------------------------------------------

MQTT_CONNACK = 2
MQTT_PUBLISH = 3
MQTT_SUBACK = 9
MQTT_PINGRESP = 13
MQTT_PINGREQ = b"\xc0\x00"
MQTT_DISCONNECT = b"\xe0\x00"


def mqtt_varint(n: int) -> bytes:
    """Encode an MQTT remaining length (1 to 4 bytes, 7 bits each, low group first)."""
    if not 0 <= n <= 268_435_455:
        raise ValueError(f"remaining length out of range: {n}")
    out = bytearray()
    while True:
        byte, n = n & 0x7F, n >> 7
        out.append(byte | (0x80 if n else 0))
        if not n:
            return bytes(out)


def mqtt_read_varint(buf: bytes, pos: int) -> tuple[int, int] | None:
    """Decode a remaining length at `pos`; return (value, next pos) or None when incomplete."""
    value = 0
    for i in range(4):
        if pos + i >= len(buf):
            return None
        byte = buf[pos + i]
        value |= (byte & 0x7F) << (7 * i)
        if not byte & 0x80:
            return value, pos + i + 1
    raise ValueError("MQTT remaining length longer than 4 bytes")


def _mqtt_str(text: str) -> bytes:
    data = text.encode()
    return struct.pack(">H", len(data)) + data


def _mqtt_packet(first: int, body: bytes) -> bytes:
    return bytes([first]) + mqtt_varint(len(body)) + body


def mqtt_connect(client_id: str, keepalive: int = 600) -> bytes:
    """Encode CONNECT: protocol "MQTT" level 4, clean session, no will, no credentials."""
    header = _mqtt_str("MQTT") + bytes([4, 0x02]) + struct.pack(">H", keepalive)
    return _mqtt_packet(0x10, header + _mqtt_str(client_id))


def mqtt_subscribe(packet_id: int, filters: list[str], qos: int = 0) -> bytes:
    """Encode SUBSCRIBE (fixed-header flags 0b0010) for `filters`, all at `qos`."""
    if not filters:
        raise ValueError("SUBSCRIBE needs at least one filter")
    body = struct.pack(">H", packet_id) + b"".join(_mqtt_str(f) + bytes([qos]) for f in filters)
    return _mqtt_packet(0x82, body)


def mqtt_publish(topic: str, data: bytes) -> bytes:
    """Encode PUBLISH at QoS 0, no retain, no dup (so no packet id)."""
    return _mqtt_packet(0x30, _mqtt_str(topic) + data)


def mqtt_split(buf: bytes) -> tuple[list[tuple[int, bytes]], int]:
    """Split complete packets off `buf`; return ([(type, body)], bytes consumed)."""
    packets: list[tuple[int, bytes]] = []
    pos = 0
    while pos < len(buf):
        length = mqtt_read_varint(buf, pos + 1)
        if length is None or length[1] + length[0] > len(buf):
            break
        size, start = length
        packets.append((buf[pos] >> 4, bytes(buf[start : start + size])))
        pos = start + size
    return packets, pos


def mqtt_publish_payload(body: bytes) -> tuple[str, bytes]:
    """Return (topic, payload) of a QoS 0 PUBLISH body."""
    if len(body) < 2:
        raise ValueError("PUBLISH body too short")
    (n,) = struct.unpack_from(">H", body)
    if 2 + n > len(body):
        raise ValueError("PUBLISH topic overruns the packet")
    return body[2 : 2 + n].decode(), body[2 + n :]


# --- NATS text protocol -------------------------------------------------------------------------

NATS_PING = b"PING\r\n"
NATS_PONG = b"PONG\r\n"


def nats_connect() -> bytes:
    """Encode CONNECT without +OK acknowledgements (verbose off)."""
    return b'CONNECT {"verbose":false,"pedantic":false,"name":"bench"}\r\n'


def nats_sub(subject: str, sid: int) -> bytes:
    """Encode SUB."""
    return f"SUB {subject} {sid}\r\n".encode()


def nats_pub(subject: str, data: bytes) -> bytes:
    """Encode PUB with its payload."""
    return f"PUB {subject} {len(data)}\r\n".encode() + data + b"\r\n"


def nats_parse(buf: bytes) -> tuple[list[tuple[str, str, str, bytes]], int]:
    """Parse server operations; return ([(op, subject, sid, payload)], bytes consumed).

    MSG yields ("MSG", subject, sid, payload); INFO, -ERR yield their argument text as subject;
    PING, PONG and +OK yield empty fields. An unknown operation raises ValueError.
    """
    events: list[tuple[str, str, str, bytes]] = []
    pos = 0
    while True:
        eol = buf.find(b"\r\n", pos)
        if eol < 0:
            break
        line = bytes(buf[pos:eol])
        op, _, rest = line.partition(b" ")
        op_name = op.upper().decode("ascii", "replace")
        if op_name == "MSG":
            parts = rest.split()
            if len(parts) not in (3, 4) or not parts[-1].isdigit():
                raise ValueError(f"bad MSG line: {line!r}")
            size = int(parts[-1])
            if eol + 2 + size + 2 > len(buf):
                break
            data = bytes(buf[eol + 2 : eol + 2 + size])
            if buf[eol + 2 + size : eol + 4 + size] != b"\r\n":
                raise ValueError("MSG payload not followed by CRLF")
            events.append(("MSG", parts[0].decode(), parts[1].decode(), data))
            pos = eol + 4 + size
            continue
        if op_name in ("INFO", "-ERR"):
            events.append((op_name, rest.decode("utf-8", "replace"), "", b""))
        elif op_name in ("PING", "PONG", "+OK"):
            events.append((op_name, "", "", b""))
        else:
            raise ValueError(f"unknown NATS operation: {line[:60]!r}")
        pos = eol + 2
    return events, pos


# --- RESP (Redis) -------------------------------------------------------------------------------

RespValue = bytes | int | str | list["RespValue"] | None


class RespError(str):
    """A RESP error reply ("-ERR ...")."""


def resp_command(*args: bytes | str) -> bytes:
    """Encode a command as a RESP array of bulk strings."""
    parts = [f"*{len(args)}\r\n".encode()]
    for arg in args:
        data = arg.encode() if isinstance(arg, str) else arg
        parts.append(b"$%d\r\n%b\r\n" % (len(data), data))
    return b"".join(parts)


def resp_parse(buf: bytes, pos: int = 0) -> tuple[RespValue, int] | None:
    """Parse one reply at `pos`; return (value, next pos) or None when incomplete.

    Simple strings come back as `str`, errors as `RespError`, integers as `int`, bulk strings as
    `bytes` (None for the null bulk), arrays as lists.
    """
    eol = buf.find(b"\r\n", pos)
    if eol < 0:
        return None
    kind, text = buf[pos : pos + 1], bytes(buf[pos + 1 : eol])
    if kind == b"+":
        return text.decode(), eol + 2
    if kind == b"-":
        return RespError(text.decode()), eol + 2
    if kind == b":":
        return int(text), eol + 2
    if kind == b"$":
        size = int(text)
        if size < 0:
            return None, eol + 2
        if eol + 4 + size > len(buf):
            return None
        if buf[eol + 2 + size : eol + 4 + size] != b"\r\n":
            raise ValueError("bulk string not followed by CRLF")
        return bytes(buf[eol + 2 : eol + 2 + size]), eol + 4 + size
    if kind == b"*":
        items: list[RespValue] = []
        at = eol + 2
        for _ in range(int(text)):
            parsed = resp_parse(buf, at)
            if parsed is None:
                return None
            items.append(parsed[0])
            at = parsed[1]
        return items, at
    raise ValueError(f"unknown RESP type byte {kind!r}")


def resp_parse_all(buf: bytes) -> tuple[list[RespValue], int]:
    """Parse every complete reply in `buf`; return (values, bytes consumed)."""
    values: list[RespValue] = []
    pos = 0
    while pos < len(buf):
        parsed = resp_parse(buf, pos)
        if parsed is None:
            break
        values.append(parsed[0])
        pos = parsed[1]
    return values, pos
