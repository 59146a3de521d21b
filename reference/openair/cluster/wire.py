"""What a cluster node writes to NATS and reads back (spec 17, issue #22): the cluster's
address, the whiteboards' stream names and subjects, and the payload of a stored copy."""

from __future__ import annotations

import struct
from dataclasses import dataclass

from openair.protocol.codec import decode_message, to_frame
from openair.protocol.fastcodec import derived
from openair.protocol.framing import binary_sizes
from openair.protocol.message import Message
from openair.server.core.store import StoreSpecError

__all__ = [
    "ClusterSpec",
    "decode_copy",
    "decode_payload",
    "encode_copy",
    "parse_spec",
    "stream_name",
    "subject",
]

_LEN = struct.Struct(">I")
_PREFIX = "openair.wb."


@dataclass(frozen=True, slots=True)
class ClusterSpec:
    """Which cluster to join: the node's name and the NATS servers to try, in order."""

    node: str
    urls: tuple[str, ...]
    timeout_s: float = 5.0


def parse_spec(spec: str) -> ClusterSpec:
    """Read `NODE@nats://HOST:PORT[,nats://…]` (the `cluster:` store of `openair serve`)."""
    node, sep, rest = spec.rpartition("@")
    urls = tuple(u.strip() for u in (rest if sep else spec).split(",") if u.strip())
    if not urls or any(not u.startswith(("nats://", "tls://")) for u in urls):
        raise StoreSpecError(f"bad cluster address {spec!r}: give nats://HOST:PORT[,...]")
    return ClusterSpec(node=node or "node", urls=urls)


def stream_name(whiteboard: str) -> str:
    """The JetStream stream of a whiteboard (any name: hex keeps it a valid stream name)."""
    return "OAWB_" + whiteboard.encode().hex()


def subject(whiteboard: str) -> str:
    """The subject posts to `whiteboard` are published on."""
    return _PREFIX + whiteboard.encode().hex()


def encode_copy(msg: Message) -> bytes:
    """One stored copy as a JetStream payload: XML length, canonical XML, binary chunks."""
    frame = to_frame(msg)
    return b"".join((_LEN.pack(len(frame.xml)), frame.xml, *frame.chunks))


def decode_copy(payload: bytes, wbid: int) -> Message | None:
    """Decode a payload written by `encode_copy`, its wbid set; None when it does not decode."""
    msg = decode_payload(payload)
    return None if msg is None else derived(msg, wbid=wbid)


def decode_payload(payload: bytes) -> Message | None:
    """Decode a payload written by `encode_copy` as it was; None when it does not decode."""
    try:
        (size,) = _LEN.unpack_from(payload)
        xml = payload[4 : 4 + size]
        binary = payload[4 + size :]
        chunks: list[bytes] = []
        pos = 0
        for n in binary_sizes(xml):
            chunks.append(binary[pos : pos + n])
            pos += n
        if pos != len(binary):
            return None
        return decode_message(xml, tuple(chunks))
    except Exception:  # a payload another program published on our subject: skip it
        return None
