"""The media commands' content and replies, on the server's side (spec 11.2-11.7).

What `StreamService` reads from a request's content (sample ids and ranges, times, a
`<samplesearch>`, a run-time `<stream>`, the chunks of ADD_SAMPLE(S)) and the DATASAMPLE(S)
replies and pushed samples it writes. Written here, independently of the client's
`openair.client.stream_wire`, so that a shared bug cannot make the server and a client agree.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from lxml import etree

from openair.protocol.codec import encode_message, time_from_element
from openair.protocol.datasample import DataSample, decode_chunk
from openair.protocol.errors import (
    ContentInvalidError,
    MessageInvalidError,
    OpenAIRError,
    SampleInvalidError,
)
from openair.protocol.fastcodec import fast_encode_str
from openair.protocol.framing import Frame, FrameTag, encode_frame
from openair.protocol.message import Message, Slot
from openair.protocol.objects import (
    attr,
    elements,
    inner_text,
    parse_content,
    parse_integer,
    parse_time,
    time_bound,
)
from openair.protocol.xmlsafe import local_name
from openair.server.core import commands as cmd
from openair.server.core.config import StreamConfig
from openair.server.core.streamspec import StoredSample

__all__ = [
    "DATASAMPLE_XML",
    "MAX_PATTERN_BYTES",
    "id_range",
    "integer_content",
    "push_frame",
    "push_message",
    "sample_reply",
    "sample_search",
    "samples_of",
    "samples_reply",
    "stream_config",
    "time_ms",
    "time_pair",
]

DATASAMPLE_XML = "<datasample/>"
_HEX = re.compile(r"[0-9A-Fa-f]+")
MAX_PATTERN_BYTES = 256  # OA-XSTREAM-11


def sample_reply(req: Message, sample: StoredSample, *, sender: str, now_ns: int) -> Message:
    """Build a DATASAMPLE reply carrying one sample as its chunk (11.2, OA-STREAM-6)."""
    return Message.trusted(
        type="DATASAMPLE",
        id=cmd.fresh_id(),
        sender=sender,
        to=req.sender,
        isresponse=req.id,
        posted=cmd.ms_time(now_ns),
        content=DATASAMPLE_XML,
        content_is_xml=True,
        language="xml",
        binary=(sample.chunk(),),
    )


def samples_reply(
    req: Message, samples: Sequence[StoredSample], *, sender: str, now_ns: int
) -> Message:
    """Build a DATASAMPLES reply: a collection of datasamples, oldest first, and their chunks."""
    objects = "<object><datasample/></object>" * len(samples)
    return Message.trusted(
        type="DATASAMPLES",
        id=cmd.fresh_id(),
        sender=sender,
        to=req.sender,
        isresponse=req.id,
        posted=cmd.ms_time(now_ns),
        content=f"<objectcollection>{objects}</objectcollection>",
        content_is_xml=True,
        language="xml",
        binary=tuple(s.chunk() for s in samples),
    )


def push_message(
    sample: StoredSample, *, stream: str, to: str, dropped: int, now_ns: int
) -> Message:
    """Build a pushed DATASAMPLE (OA-STREAM-8, OA-STREAM-12), with `dropped` when samples were."""
    extras = (Slot(name="dropped", value=str(dropped)),) if dropped else ()
    return Message.trusted(
        type="DATASAMPLE",
        id=cmd.fresh_id(),
        sender=stream,
        to=to,
        posted=cmd.ms_time(now_ns),
        content=DATASAMPLE_XML,
        content_is_xml=True,
        language="xml",
        extras=extras,
        binary=(sample.chunk(),),
    )


def push_frame(msg: Message) -> tuple[bytes, ...]:
    """Write a DATASAMPLE message built here as frame parts: header and XML, then its chunks.

    The content (`<datasample/>`) is this module's own XML, so the fast encoder may splice it
    (no lxml per pushed sample); the chunks are the stored bytes, written without a copy.
    """
    text = fast_encode_str(msg, xml_content=True)
    xml = text.encode("utf-8") if text is not None else encode_message(msg)
    return (encode_frame(Frame(tag=FrameTag.MESSAGE, xml=xml)), *msg.binary)


def samples_of(msg: Message) -> tuple[DataSample, ...]:
    """Decode the samples of ADD_SAMPLE / ADD_SAMPLES (OA-STREAM-5, OA-STREAM-10)."""
    chunks = msg.binary
    if msg.type == "ADD_SAMPLE" and len(chunks) != 1:
        raise SampleInvalidError(f"ADD_SAMPLE must carry one datasample chunk, not {len(chunks)}")
    if not chunks:
        raise SampleInvalidError("ADD_SAMPLES carries no datasample chunk")
    if msg.type == "ADD_SAMPLES":
        declared = _datasample_count(msg.content)
        if declared != len(chunks):
            raise SampleInvalidError(
                f"the content names {declared} datasamples but {len(chunks)} chunks follow"
            )
    return tuple(decode_chunk(chunk) for chunk in chunks)


def _datasample_count(content: str) -> int:
    try:
        roots = parse_content(content, SampleInvalidError)
    except OpenAIRError as exc:
        raise SampleInvalidError(f"ADD_SAMPLES content: {exc.detail}") from None
    return sum(
        1
        for root in roots
        for el in root.iter()
        if isinstance(el.tag, str) and local_name(el) == "datasample"
    )


def integer_content(content: str, what: str) -> int:
    value = parse_integer(content)
    if value is None:
        raise ContentInvalidError(f"the content must be a {what}, not {content[:40]!r}")
    return value


def id_range(content: str) -> tuple[int, int]:
    first, sep, last = content.strip().partition("-")
    low, high = parse_integer(first), parse_integer(last)
    if not sep or low is None or high is None or low > high:
        raise ContentInvalidError(
            f"the content must be a range of ids first-last, not {content[:40]!r}"
        )
    return low, high


def _time_of(el: etree._Element) -> int:
    try:
        return time_from_element(el).ms
    except MessageInvalidError as exc:
        raise ContentInvalidError(f"time: {exc.detail}") from None


def time_ms(content: str) -> int:
    """Read content that is one time element (or, leniently, milliseconds since the epoch)."""
    text = content.strip()
    if text and not text.startswith("<"):
        return integer_content(text, "time element")
    return parse_time(content).ms  # CONTENT_INVALID when it is not one time element


def time_pair(content: str) -> tuple[int, int]:
    """Read the `<objectcollection>` of two times of GET_SAMPLES_BY_TIME (from, until)."""
    roots = parse_content(content, ContentInvalidError)
    times = [
        _time_of(inner)
        for root in roots
        for obj in (elements(root) if local_name(root) == "objectcollection" else [root])
        for inner in (elements(obj) if local_name(obj) == "object" else [obj])
    ]
    if len(times) != 2:
        raise ContentInvalidError("GET_SAMPLES_BY_TIME needs two times (from, until)")
    return times[0], times[1]


def sample_search(content: str) -> tuple[int | None, int | None, list[tuple[str, str]], int, bytes]:
    """Read `<samplesearch>` (OA-XSTREAM-9, with `<payload>` OA-XSTREAM-11)."""
    roots = parse_content(content, ContentInvalidError)
    if len(roots) != 1 or local_name(roots[0]) != "samplesearch":
        raise ContentInvalidError("SEARCH_SAMPLES content must be one <samplesearch>")
    after = until = None
    params: list[tuple[str, str]] = []
    latest = 0
    payload = b""
    seen: set[str] = set()
    for child in elements(roots[0]):
        kind = local_name(child)
        if kind != "param" and kind in seen:
            raise ContentInvalidError(f"<samplesearch> holds <{kind}> twice")
        seen.add(kind)
        if kind == "aftertime":
            after = time_bound(child, "afterTime", ContentInvalidError).ms  # as OA-RET-9
        elif kind == "untiltime":
            until = time_bound(child, "untilTime", ContentInvalidError).ms
        elif kind == "param":
            key = attr(child, "name")
            if not key:
                raise ContentInvalidError("<param> needs a name")
            params.append((key, inner_text(child)))
        elif kind == "latest":
            latest = integer_content(inner_text(child), "count")
        elif kind == "payload":
            payload = _byte_pattern(inner_text(child))  # OA-XSTREAM-11
        else:
            raise ContentInvalidError(f"<samplesearch> holds <{kind}>")
    return after, until, params, max(latest, 0), payload


def _byte_pattern(text: str) -> bytes:
    """Read a `<payload>` byte pattern: 1-256 bytes as hex pairs, spaces between (OA-XSTREAM-11)."""
    pairs = text.split()
    if not all(len(p) % 2 == 0 and _HEX.fullmatch(p) for p in pairs):
        raise ContentInvalidError(f"<payload> {text[:40]!r} is not bytes in hexadecimal")
    pattern = bytes.fromhex("".join(pairs))
    if not 1 <= len(pattern) <= MAX_PATTERN_BYTES:
        raise ContentInvalidError(f"<payload> holds {len(pattern)} bytes, not 1 to 256")
    return pattern


def stream_config(el: etree._Element, name: str) -> StreamConfig:
    """Read a run-time `<stream>` like a psySpec one (OA-XSTREAM-10)."""
    known = ("name", "whiteboard", "maxsize", "maxcount")
    other = tuple((str(k), str(v)) for k, v in el.attrib.items() if str(k) not in known)
    try:
        maxsize = float(attr(el, "maxsize") or "10")
        maxcount = int(attr(el, "maxcount") or "0")
    except ValueError as exc:
        raise ContentInvalidError(f"<stream>: {exc}") from None
    if not maxsize > 0 or maxcount < 0:
        raise ContentInvalidError("<stream> maxsize must be > 0 and maxcount >= 0")
    return StreamConfig(name=name, maxsize=maxsize, maxcount=maxcount, attributes=other)
