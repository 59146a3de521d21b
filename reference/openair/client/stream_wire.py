"""Stream requests and replies as values, without I/O (spec section 11, STREAMS.md section 2).

The client's stream side (`streams.py`) builds its media commands here and reads the replies
here: sample chunks are decoded with `openair.protocol.datasample.decode_chunk` (a memoryview slice
of the received chunk, no copy), times travel as one `<time sec msec/>` element, `streaminfo`
attributes become a `StreamInfo`, alarm posts become a `StreamAlarm`. A reply that does not have
the shape the contract gives is CONTENT_INVALID (or SAMPLE_INVALID for a bad chunk).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from lxml import etree

from openair.protocol.datasample import (
    BUILTIN_SEQ,
    BUILTIN_TIMESTAMP,
    DATASAMPLE_XML,
    DataSample,
    decode_chunk,
)
from openair.protocol.errors import ApiMisuseError, ContentInvalidError, SampleInvalidError
from openair.protocol.message import Message
from openair.protocol.objects import (
    attr,
    element,
    elements,
    encode_time,
    inner_text,
    parse_dictionary,
    parse_integer,
    parse_root,
    parse_time,
    serialize,
)
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import local_name

ALARM_PREFIX = "AIR.Stream.Alarm."

#: A time as the client API takes it: milliseconds since the epoch, or an `AirTime`.
TimeArg = int | AirTime


@dataclass(frozen=True, slots=True, kw_only=True)
class ReceivedSample:
    """A sample pushed to this client: by a push subscription or a registration (OA-STREAM-14).

    `stream` is the stream's name (the `from` of the DATASAMPLE message); `dropped` is how many
    samples the server dropped for this subscriber since the previous one it sent (OA-STREAM-8);
    `received_ns` was read from the clock when the bytes arrived.
    """

    stream: str
    sample: DataSample
    dropped: int = 0
    received_ns: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamInfo:
    """One `<streaminfo>` (GET_INFO, GET_STREAMS): sizes in bytes, ids, counts.

    `oldest` and `newest` are sample ids (None when the stream is empty); `type` is "" for an
    untyped stream; soft and hard limits are None when the server does not report them.
    `extra` keeps any other attribute, in document order.
    """

    name: str
    whiteboard: str = ""
    type: str = ""
    count: int = 0
    size: int = 0
    oldest: int | None = None
    newest: int | None = None
    maxsize: int = 0
    maxcount: int = 0
    softsize: int | None = None
    softcount: int | None = None
    hardsize: int | None = None
    hardcount: int | None = None
    subscribers: int = 0
    writers: int = 0
    idle: int | None = None
    locked: int = 0
    extra: tuple[tuple[str, str], ...] = ()

    def as_dict(self) -> dict[str, str | int | None]:
        """Return the attributes as a dict (JSON friendly), the extra ones as text."""
        out: dict[str, str | int | None] = {
            name: getattr(self, name) for name in _INFO_FIELDS if name != "extra"
        }
        out.update(self.extra)
        return out


_INFO_INTS = ("count", "size", "maxsize", "maxcount", "subscribers", "writers", "locked")
_INFO_OPTIONAL = ("oldest", "newest", "softsize", "softcount", "hardsize", "hardcount", "idle")
_INFO_FIELDS = tuple(StreamInfo.__dataclass_fields__)


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamAlarm:
    """An alarm a typed stream posted (OA-XSTREAM-6): `AIR.Stream.Alarm.<kind>`.

    `entries` is the content's dictionary (`stream`, `streamtype`, `time` and the kind's own
    entries, e.g. `dropped` for HardLimit); `message` is the stored post.
    """

    kind: str
    stream: str
    entries: Mapping[str, str] = field(default_factory=dict)
    message: Message | None = None


# --------------------------------------------------------------------------------- requests


def make_sample(
    payload: bytes | bytearray | memoryview | DataSample,
    params: Mapping[str, str] | None = None,
    *,
    timestamp_ms: int | None = None,
    seq: int | None = None,
) -> DataSample:
    """Build the sample to write: `params` in order, then `builtin:timestamp` and `builtin:seq`.

    The payload is not copied (a bytearray is viewed, not converted). A DataSample keeps its
    parameters; `params`, `timestamp_ms` and `seq` replace keys in place or append them.
    """
    if isinstance(payload, DataSample):
        sample = payload
    else:
        body = payload if isinstance(payload, bytes) else memoryview(payload)
        sample = DataSample(payload=body)
    updates = dict(params or {})
    if timestamp_ms is not None:
        if timestamp_ms < 0:
            raise ApiMisuseError(f"a timestamp must not be negative: {timestamp_ms}")
        updates[BUILTIN_TIMESTAMP] = str(timestamp_ms)
    if seq is not None:
        updates[BUILTIN_SEQ] = str(seq)  # OA-XSTREAM-8
    return sample.with_params(updates)


def media_request(
    target: str, sender: str, type: str, content: str = "", *, xml: bool = False
) -> Message:
    """Build a media command to the stream `target` (its name or type), from `sender`."""
    return Message(
        type=type,
        sender=sender,
        to=target,
        content=content,
        content_is_xml=xml,
        language="xml" if xml else "",
    )


def add_sample_request(target: str, sender: str, *, noreply: bool = False) -> Message:
    """ADD_SAMPLE: `<datasample/>`; its one chunk is sent after the XML (OA-STREAM-5)."""
    msg = media_request(target, sender, "ADD_SAMPLE", DATASAMPLE_XML, xml=True)
    return _noreply(msg) if noreply else msg


def add_samples_request(target: str, sender: str, count: int, *, noreply: bool = False) -> Message:
    """ADD_SAMPLES: an objectcollection of `count` `<datasample/>` objects, one chunk each."""
    if count < 1:
        raise ApiMisuseError("ADD_SAMPLES needs at least one sample")
    body = f"<object>{DATASAMPLE_XML}</object>" * count
    msg = media_request(
        target, sender, "ADD_SAMPLES", f"<objectcollection>{body}</objectcollection>", xml=True
    )
    return _noreply(msg) if noreply else msg


def _noreply(msg: Message) -> Message:
    return replace(msg, noreply=True)  # OA-MSG-15, only when the server advertises noreply


def air_time(t: TimeArg) -> AirTime:
    """Return `t` (ms since the epoch or an AirTime) as an AirTime."""
    return t if isinstance(t, AirTime) else AirTime.from_ms(t)


def time_content(t: TimeArg) -> str:
    """One time element `<time sec msec/>` (GET_SAMPLE_BY_TIME, WAIT_FOR_*_SAMPLE)."""
    return encode_time("time", air_time(t))


def range_content(first: TimeArg, last: TimeArg) -> str:
    """GET_SAMPLES_BY_TIME: an objectcollection of two objects holding the bounds."""
    return (
        f"<objectcollection><object>{time_content(first)}</object>"
        f"<object>{time_content(last)}</object></objectcollection>"
    )


def wait_type(*, by_id: bool, last: bool, timeout_ms: int) -> str:
    """The type of a waiting command: name, one space, the timeout in ms (spec 11.5)."""
    if timeout_ms < 0:
        raise ApiMisuseError(f"a wait timeout must not be negative: {timeout_ms}")
    which = "LAST" if last else "FIRST"
    what = "AFTERID" if by_id else "SAMPLE"
    return f"WAIT_FOR_{which}_{what} {timeout_ms}"


def search_content(
    *,
    after: TimeArg | None = None,
    until: TimeArg | None = None,
    params: Mapping[str, str] | None = None,
    latest: int = 0,
) -> str:
    """SEARCH_SAMPLES content `<samplesearch>` (OA-XSTREAM-9); times as epoch ms text."""
    if latest < 0:
        raise ApiMisuseError(f"latest must not be negative: {latest}")
    root = element("samplesearch")
    if after is not None:
        root.append(element("afterTime", text=str(air_time(after).ms)))
    if until is not None:
        root.append(element("untilTime", text=str(air_time(until).ms)))
    for key, glob in (params or {}).items():
        root.append(element("param", (("name", key),), glob))
    if latest:
        root.append(element("latest", text=str(latest)))
    return serialize(root)


def lock_content(first: int, last: int) -> str:
    """LOCK_SAMPLES content: the id range `first-last` (OA-XSTREAM-5)."""
    if first < 0 or last < 0:
        raise ApiMisuseError(f"sample ids are not negative: {first}-{last}")
    return f"{first}-{last}"


# ---------------------------------------------------------------------------------- replies


def sample_of(msg: Message) -> DataSample:
    """Read the one sample of a DATASAMPLE message (a reply or a push, OA-STREAM-12)."""
    if len(msg.binary) != 1:
        raise SampleInvalidError(f"{msg.type} carries {len(msg.binary)} chunks, not 1")
    return decode_chunk(msg.binary[0])


def samples_of(msg: Message) -> list[DataSample]:
    """Read a DATASAMPLES reply: one chunk per `<datasample>` element, oldest first."""
    if not msg.content.strip():
        marked = 0
    else:
        root = parse_root(msg.content, ("objectcollection",), ContentInvalidError)
        marked = sum(1 for el in root.iter() if _is_datasample(el))
    if marked != len(msg.binary):
        raise ContentInvalidError(
            f"{msg.type} names {marked} datasample(s) but carries {len(msg.binary)} chunk(s)"
        )
    return [decode_chunk(chunk) for chunk in msg.binary]


def _is_datasample(el: etree._Element) -> bool:
    return isinstance(el.tag, str) and local_name(el) == "datasample"


def integer_of(msg: Message, what: str) -> int:
    """Read a decimal text reply (DATA_ACCEPTED id, COUNT, SIZE, LOCKED)."""
    value = parse_integer(msg.content)
    if value is None or value < 0:
        raise ContentInvalidError(f"{msg.type}: {what} {msg.content[:40]!r} is not a count")
    return value


def ids_of(msg: Message) -> list[int]:
    """Read ADD_SAMPLES's DATA_ACCEPTED `<collection><entry>id</entry>…</collection>`."""
    root = parse_root(msg.content, ("collection",), ContentInvalidError)
    ids: list[int] = []
    for child in elements(root):
        value = parse_integer(inner_text(child))
        if local_name(child) != "entry" or value is None:
            raise ContentInvalidError(f"DATA_ACCEPTED: bad collection entry <{local_name(child)}>")
        ids.append(value)
    return ids


def timestamp_of(msg: Message) -> int:
    """Read a TIMESTAMP reply (one time element) as ms since the epoch."""
    return parse_time(msg.content).ms


def info_of(el: etree._Element) -> StreamInfo:
    """Read one `<streaminfo …/>` element (STREAMS.md section 2)."""
    if local_name(el) != "streaminfo":
        raise ContentInvalidError(f"expected <streaminfo>, found <{local_name(el)}>")
    name = attr(el, "name")
    if not name:
        raise ContentInvalidError("<streaminfo> without a name")
    values: dict[str, object] = {"name": name, "whiteboard": attr(el, "whiteboard") or ""}
    values["type"] = attr(el, "type") or ""
    for key in (*_INFO_INTS, *_INFO_OPTIONAL):
        text = attr(el, key)
        if text is None:
            continue
        number = parse_integer(text)
        if number is None:
            raise ContentInvalidError(f"<streaminfo {key}={text[:40]!r}> is not an integer")
        values[key] = number
    known = {*_INFO_FIELDS}
    values["extra"] = tuple(
        (str(k), str(v)) for k, v in el.attrib.items() if str(k).lower() not in known
    )
    return StreamInfo(**values)  # type: ignore[arg-type]  # keys are StreamInfo's fields


def stream_info_of(msg: Message) -> StreamInfo:
    """Read an INFO reply."""
    return info_of(parse_root(msg.content, ("streaminfo",), ContentInvalidError))


def stream_list_of(msg: Message) -> list[StreamInfo]:
    """Read a STREAMS reply: `<streams>` of `<streaminfo>`, in configuration order."""
    if not msg.content.strip():
        return []
    root = parse_root(msg.content, ("streams",), ContentInvalidError)
    return [info_of(el) for el in elements(root)]


def received_sample(msg: Message, received_ns: int = 0) -> ReceivedSample:
    """Read a pushed DATASAMPLE message, its `dropped` slot included (OA-STREAM-8)."""
    slot = msg.extra("dropped")
    dropped = 0
    if slot is not None:
        value = parse_integer(slot.value)
        if value is None or value < 0:
            raise ContentInvalidError(f"dropped {slot.value[:40]!r} is not a count")
        dropped = value
    return ReceivedSample(
        stream=msg.sender, sample=sample_of(msg), dropped=dropped, received_ns=received_ns
    )


def is_alarm(msg: Message) -> bool:
    """Whether `msg` is a stream alarm post (OA-XSTREAM-6)."""
    return msg.type.startswith(ALARM_PREFIX) and len(msg.type) > len(ALARM_PREFIX)


def alarm_of(msg: Message) -> StreamAlarm:
    """Read an alarm post: kind from the type, entries from the `<dictionary>` content."""
    if not is_alarm(msg):
        raise ContentInvalidError(f"{msg.type!r} is not an {ALARM_PREFIX}<Kind> alarm")
    entries = dict(parse_dictionary(msg.content).entries) if msg.content.strip() else {}
    return StreamAlarm(
        kind=msg.type[len(ALARM_PREFIX) :],
        stream=entries.get("stream") or msg.sender,
        entries=entries,
        message=msg,
    )
