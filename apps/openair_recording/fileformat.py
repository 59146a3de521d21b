"""The recording file: framed binary records with an index (docs/recording.md).

A file is the magic `OAIRREC1`, then records. A record is a one-byte tag, the body length (uint32
little-endian), the body, and the CRC-32 of tag and body (uint32 little-endian). The first record
is the header (`H`, JSON); then messages (`M`) and stream samples (`S`) in the order they were
captured; a file closed cleanly ends with the index (`I`) and the end record (`E`). Each record is
written with one write and flushed, so a crash loses at most the record being written; a reader
reads records one at a time and never needs the index.

Message bodies hold the canonical XML of the stored copy (spec 3.5) and its attachments; sample
bodies hold the datasample chunk exactly as it travels (spec 11.2). Nothing is escaped or
re-encoded: bytes come back as they went in.
"""

from __future__ import annotations

import json
import os
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from openair.protocol.codec import decode_message, encode_message
from openair.protocol.datasample import DataSample, decode_chunk, encode_chunk
from openair.protocol.errors import (
    BinarySizesInvalidError,
    FrameTooLargeError,
    FrameTruncatedError,
    FrameUnknownTagError,
    MessageInvalidError,
    OpenAIRError,
)
from openair.protocol.message import Message

__all__ = [
    "FORMAT_VERSION",
    "MAGIC",
    "MAX_RECORD",
    "Header",
    "IndexEntry",
    "MessageRecord",
    "Record",
    "RecordingReader",
    "RecordingWriter",
    "SampleRecord",
    "read_index",
]

MAGIC = b"OAIRREC1"
FORMAT_VERSION = 1
#: The largest record body a reader accepts (a longer length is hostile, not a recording).
MAX_RECORD = 1 << 30
MAX_HEADER = 1 << 20  # the JSON header
TAG_HEADER, TAG_MESSAGE, TAG_SAMPLE, TAG_INDEX, TAG_END = b"H", b"M", b"S", b"I", b"E"
_TAGS = frozenset({TAG_HEADER, TAG_MESSAGE, TAG_SAMPLE, TAG_INDEX, TAG_END})

_HEAD = struct.Struct("<cI")  # tag, body length
_CRC = struct.Struct("<I")
_U64 = struct.Struct("<Q")
_U32 = struct.Struct("<I")
_U16 = struct.Struct("<H")
_SAMPLE_HEAD = struct.Struct("<QH")  # capture time, stream name length
_ENTRY = struct.Struct("<QQc")  # offset, time (ns), tag
_END = struct.Struct("<QQQQ")  # index offset, messages, samples, stopped (ns)


@dataclass(frozen=True, slots=True, kw_only=True)
class Header:
    """What the recorder knew when it started: server, whiteboards, streams, filters."""

    server: str = ""
    started_ns: int = 0
    recorder: str = ""
    types: str = "*"
    whiteboards: tuple[str, ...] = ()
    #: One dict per recorded stream: name, whiteboard, type, maxsize (as GET_STREAMS said).
    streams: tuple[dict[str, str], ...] = ()
    extensions: tuple[str, ...] = ()
    version: int = FORMAT_VERSION

    def to_json(self) -> bytes:
        """Return the header's JSON body (UTF-8)."""
        data = {
            "format": self.version, "server": self.server, "started_ns": self.started_ns,
            "recorder": self.recorder, "types": self.types,
            "whiteboards": list(self.whiteboards), "streams": list(self.streams),
            "extensions": list(self.extensions),
        }  # fmt: skip
        return json.dumps(data, ensure_ascii=False).encode()

    @classmethod
    def from_json(cls, body: bytes) -> Header:
        """Read a header body; raise MessageInvalidError when it is not one."""
        try:
            data = json.loads(body.decode("utf-8"))
            if not isinstance(data, dict) or data.get("format") != FORMAT_VERSION:
                raise ValueError(f"format {data.get('format') if isinstance(data, dict) else '?'}")
            streams = tuple({str(k): str(v) for k, v in s.items()} for s in data["streams"])
            return cls(
                server=str(data["server"]), started_ns=int(data["started_ns"]),
                recorder=str(data["recorder"]), types=str(data["types"]),
                whiteboards=tuple(str(w) for w in data["whiteboards"]), streams=streams,
                extensions=tuple(str(e) for e in data["extensions"]),
            )  # fmt: skip
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise MessageInvalidError(f"recording header is not a format-1 header: {exc}") from None


@dataclass(frozen=True, slots=True, kw_only=True)
class MessageRecord:
    """A message the server routed: its stored copy (both times, attachments) and capture time."""

    message: Message
    captured_ns: int
    offset: int = 0

    @property
    def time_us(self) -> int:
        """When it happened: receivedTime (the whiteboard's clock), else postedTime or capture."""
        t = self.message.received or self.message.posted
        return t.us if t is not None else self.captured_ns // 1000


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class SampleRecord:
    """A stream sample: stream name, the sample (id and timestamp among its parameters)."""

    stream: str
    sample: DataSample
    captured_ns: int
    dropped: int = 0
    offset: int = 0

    @property
    def time_us(self) -> int:
        """When it happened: the stream's timestamp (OA-STREAM-4), else the capture time."""
        ts = self.sample.timestamp_ms
        return ts * 1000 if ts is not None else self.captured_ns // 1000


Record = MessageRecord | SampleRecord


@dataclass(frozen=True, slots=True, kw_only=True)
class IndexEntry:
    """Where one record starts, when it was captured, and its tag."""

    offset: int
    time_ns: int
    tag: bytes


def _frame(tag: bytes, body: bytes) -> bytes:
    return b"".join((_HEAD.pack(tag, len(body)), body, _CRC.pack(zlib.crc32(tag + body))))


def encode_message_record(msg: Message, captured_ns: int) -> bytes:
    """Return the `M` record of `msg`: capture time, XML, then its chunks with their lengths."""
    xml = encode_message(msg)
    parts = [_U64.pack(captured_ns), _U32.pack(len(xml)), xml, _U32.pack(len(msg.binary))]
    for chunk in msg.binary:
        parts += (_U32.pack(len(chunk)), chunk)
    return _frame(TAG_MESSAGE, b"".join(parts))


def encode_sample_record(stream: str, sample: DataSample, captured_ns: int, dropped: int) -> bytes:
    """Return the `S` record: capture time, stream name, dropped count, the datasample chunk."""
    name = stream.encode()
    head = _SAMPLE_HEAD.pack(captured_ns, len(name))
    return _frame(TAG_SAMPLE, b"".join((head, name, _U32.pack(dropped), encode_chunk(sample))))


class RecordingWriter:
    """Append records to a new file; `close()` writes the index and the end record.

    Every record is written whole and flushed, so the file is readable at any moment and a
    crash loses at most the record being written.
    """

    def __init__(self, path: str | Path, header: Header) -> None:
        self.path = Path(path)
        self._file: IO[bytes] = open(self.path, "wb")  # noqa: SIM115 - closed by close()
        self._index: list[IndexEntry] = []
        self.messages = self.samples = 0
        self._file.write(MAGIC)
        self._append(TAG_HEADER, _frame(TAG_HEADER, header.to_json()), header.started_ns)

    @property
    def closed(self) -> bool:
        return self._file.closed

    def _append(self, tag: bytes, data: bytes, time_ns: int) -> None:
        self._index.append(IndexEntry(offset=self._file.tell(), time_ns=time_ns, tag=tag))
        self._file.write(data)
        self._file.flush()

    def add_message(self, msg: Message, captured_ns: int) -> None:
        """Append one routed message (its stored copy, attachments included)."""
        self._append(TAG_MESSAGE, encode_message_record(msg, captured_ns), captured_ns)
        self.messages += 1

    def add_sample(self, stream: str, sample: DataSample, captured_ns: int, dropped: int) -> None:
        """Append one stream sample."""
        data = encode_sample_record(stream, sample, captured_ns, dropped)
        self._append(TAG_SAMPLE, data, captured_ns)
        self.samples += 1

    def close(self, stopped_ns: int) -> None:
        """Write the index and the end record, flush them to disk and close the file."""
        if self._file.closed:
            return
        index_at = self._file.tell()
        entries = b"".join(_ENTRY.pack(e.offset, e.time_ns, e.tag) for e in self._index)
        self._file.write(_frame(TAG_INDEX, entries))
        end = _END.pack(index_at, self.messages, self.samples, stopped_ns)
        self._file.write(_frame(TAG_END, end))
        self._file.flush()
        os.fsync(self._file.fileno())
        self._file.close()


@dataclass(slots=True)
class RecordingReader:
    """Read a recording record by record (streaming); `warnings` says what was cut off.

    A file cut inside its last record (a crash while recording) is read up to the last whole
    record and says so in `warnings`. A hostile or corrupt file raises an error of the error
    table naming the offset: FrameUnknownTagError (not a recording, unknown tag),
    FrameTooLargeError (a length over MAX_RECORD), BinarySizesInvalidError (lengths inside a
    record that do not add up, a checksum that does not match before the end), and the codec's
    errors for the XML of a message (XmlForbiddenError for a DOCTYPE, OA-SEC-1).
    """

    path: Path
    header: Header = field(default_factory=Header)
    warnings: list[str] = field(default_factory=list)
    complete: bool = False  # the end record was read: the recorder stopped cleanly

    @classmethod
    def open(cls, path: str | Path) -> RecordingReader:
        """Return a reader of `path` whose header has been read; raise on a bad file."""
        reader = cls(Path(path))
        with open(reader.path, "rb") as f:
            reader._magic(f)
            first = reader._next(f)
            if first is None and reader.warnings:  # cut inside the header: nothing to read
                raise FrameTruncatedError(reader.warnings[0])
            if first is None or first[0] != TAG_HEADER:
                raise FrameUnknownTagError(f"{reader.path}: no header record after the magic")
            try:
                reader.header = Header.from_json(first[2])
            except OpenAIRError as exc:
                raise type(exc)(f"{reader.path}: {exc.detail}") from None
        return reader

    def _magic(self, f: IO[bytes]) -> None:
        if f.read(len(MAGIC)) != MAGIC:
            raise FrameUnknownTagError(f"{self.path}: not an OpenAIR recording (no OAIRREC1)")

    def records(self) -> Iterator[Record]:
        """Yield the messages and samples in file order (the header was read by open)."""
        self.warnings.clear()
        with open(self.path, "rb") as f:
            self._magic(f)
            self._next(f)
            while (item := self._next(f)) is not None:
                tag, offset, body = item
                if tag in (TAG_MESSAGE, TAG_SAMPLE):
                    yield self._decode(tag, offset, body)
                elif tag == TAG_END:
                    self.complete = True
            if not self.complete and not self.warnings:
                self.warnings.append(f"{self.path}: no end record (the recorder did not stop)")

    def _decode(self, tag: bytes, offset: int, body: bytes) -> Record:
        try:
            return _message(body, offset) if tag == TAG_MESSAGE else _sample(body, offset)
        except OpenAIRError as exc:
            raise type(exc)(f"{self.path}: {exc.detail}") from None

    def _next(self, f: IO[bytes]) -> tuple[bytes, int, bytes] | None:
        """Read one whole record; None at the end or after a cut-off last record (warned)."""
        offset = f.tell()
        head = f.read(_HEAD.size)
        if not head:
            return None
        if len(head) < _HEAD.size:
            self._cut(offset, len(head))
            return None
        tag, size = _HEAD.unpack(head)
        if tag not in _TAGS:
            raise FrameUnknownTagError(f"{self.path}: unknown record tag {tag!r} at {offset}")
        limit = MAX_HEADER if tag == TAG_HEADER else MAX_RECORD
        if size > limit:
            raise FrameTooLargeError(f"{self.path}: {size}-byte record at {offset} (max {limit})")
        rest = f.read(size + _CRC.size)
        if len(rest) < size + _CRC.size:
            self._cut(offset, len(head) + len(rest))
            return None
        body = rest[:size]
        if _CRC.unpack(rest[size:])[0] != zlib.crc32(tag + body):
            if f.read(1):
                raise BinarySizesInvalidError(f"{self.path}: record at {offset}: bad checksum")
            self._cut(offset, len(head) + len(rest))  # a torn last write
            return None
        return tag, offset, body

    def _cut(self, offset: int, kept: int) -> None:
        self.warnings.append(
            f"{self.path}: truncated: the record at byte {offset} is incomplete ({kept} bytes); "
            "read up to the last whole record"
        )


def _take(body: bytes, pos: int, size: int, what: str, offset: int) -> tuple[bytes, int]:
    """Return body[pos:pos+size] and the next position; raise when the body is too short."""
    if pos + size > len(body):
        raise BinarySizesInvalidError(
            f"record at {offset}: {what} of {size} bytes runs past the record's end"
        )
    return body[pos : pos + size], pos + size


def _u32(body: bytes, pos: int, what: str, offset: int) -> tuple[int, int]:
    raw, pos = _take(body, pos, 4, what, offset)
    return _U32.unpack(raw)[0], pos


def _message(body: bytes, offset: int) -> MessageRecord:
    raw, pos = _take(body, 0, 8, "capture time", offset)
    size, pos = _u32(body, pos, "XML length", offset)
    xml, pos = _take(body, pos, size, "message XML", offset)
    count, pos = _u32(body, pos, "attachment count", offset)
    chunks: list[bytes] = []
    for i in range(count):
        length, pos = _u32(body, pos, f"attachment {i + 1} length", offset)
        chunk, pos = _take(body, pos, length, f"attachment {i + 1}", offset)
        chunks.append(chunk)
    if pos != len(body):
        raise BinarySizesInvalidError(f"record at {offset}: {len(body) - pos} bytes left over")
    try:
        msg = decode_message(xml, tuple(chunks))  # the hardened parser (OA-SEC-1/2)
    except OpenAIRError as exc:
        raise type(exc)(f"record at {offset}: {exc}") from None
    return MessageRecord(message=msg, captured_ns=_U64.unpack(raw)[0], offset=offset)


def _sample(body: bytes, offset: int) -> SampleRecord:
    raw, pos = _take(body, 0, _SAMPLE_HEAD.size, "sample head", offset)
    captured, name_size = _SAMPLE_HEAD.unpack(raw)
    name, pos = _take(body, pos, name_size, "stream name", offset)
    dropped, pos = _u32(body, pos, "dropped count", offset)
    try:
        sample = decode_chunk(body[pos:])
        stream = name.decode("utf-8")
    except (OpenAIRError, UnicodeDecodeError) as exc:
        raise BinarySizesInvalidError(f"record at {offset}: bad sample: {exc}") from None
    return SampleRecord(
        stream=stream, sample=sample, captured_ns=captured, dropped=dropped, offset=offset
    )


def read_index(path: str | Path) -> list[IndexEntry] | None:
    """Return the index of a cleanly closed recording, or None (no end record: read it all)."""
    p = Path(path)
    size = p.stat().st_size
    end_size = _HEAD.size + _END.size + _CRC.size
    with open(p, "rb") as f:
        if size < len(MAGIC) + end_size:
            return None
        f.seek(size - end_size)
        if f.read(_HEAD.size) != _HEAD.pack(TAG_END, _END.size):
            return None  # no end record: the recorder did not stop cleanly
        f.seek(size - end_size)
        reader = RecordingReader(p)
        item = reader._next(f)
        if item is None:
            return None
        index_at = _END.unpack(item[2])[0]
        if not len(MAGIC) <= index_at < size - end_size:
            raise BinarySizesInvalidError(f"{p}: index offset {index_at} outside the file")
        f.seek(index_at)
        entry = reader._next(f)
    if entry is None or entry[0] != TAG_INDEX or len(entry[2]) % _ENTRY.size:
        raise BinarySizesInvalidError(f"{p}: the end record does not point at an index")
    out = [_ENTRY.unpack_from(entry[2], i) for i in range(0, len(entry[2]), _ENTRY.size)]
    return [IndexEntry(offset=o, time_ns=t, tag=g) for o, t, g in out]
