"""Recorded histories: the messages a system posted, from a store, a live server or a file.

A history source is one of:

- `sqlite:PATH`: the reference server's SQLite store (`openair serve --store sqlite:PATH`,
  OA-WB-9), opened read-only so a running server is not disturbed;
- `HOST:PORT`: a running server; every whiteboard is retrieved with `type="*"` and no limit
  (AIR.Retrieve, spec 9), the whiteboards named by STATUS (`whiteboards.NAME.*` entries,
  OA-SESS-25 allows them) or given by the caller, else AIRCentral, WB1 and WB2;
- a file: an `<objectcollection>` of `<object><message>…` (what a retrieve returns, OA-RET-7),
  for example saved from `openair retrieve`.
"""

from __future__ import annotations

import asyncio
import sqlite3
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from openair.client.module import FailedReplyError, Module
from openair.protocol.address import parse_server
from openair.protocol.codec import decode_message
from openair.protocol.content import RetrieveSpec
from openair.protocol.errors import ConnectionClosedError, OpenAIRError
from openair.protocol.framing import binary_sizes
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary, read_message_collection
from openair.protocol.xmlsafe import XmlLimits, parse_xml

__all__ = [
    "DEFAULT_WHITEBOARDS",
    "History",
    "HistoryConnectError",
    "HistoryError",
    "history_of_recording",
    "load_history",
    "read_sqlite",
    "read_xml",
    "retrieve_live",
]

DEFAULT_WHITEBOARDS = ("AIRCentral", "WB1", "WB2")  # OA-WB-1: a server without configuration
CLIENT_NAME = "openair-ontology"
MAX_HISTORY_BYTES = 1024 * 1024 * 1024  # a file the user chose; bounded all the same


class HistoryError(Exception):
    """A history source that cannot be read (a usage error: bad name, file or content)."""


class HistoryConnectError(HistoryError):
    """The server of a `HOST:PORT` history could not be reached or was lost."""


@dataclass(frozen=True, slots=True, kw_only=True)
class History:
    """The messages of one source, oldest first, and notes about what was skipped."""

    source: str
    messages: tuple[Message, ...] = ()
    notes: tuple[str, ...] = ()


def load_history(spec: str, *, whiteboards: Sequence[str] = (), timeout: float = 10.0) -> History:
    """Read the history source `spec` (see the module docstring); raise HistoryError."""
    if spec.startswith("sqlite:"):
        return read_sqlite(spec.removeprefix("sqlite:"))
    path = Path(spec)
    _, sep, _ = spec.rpartition(":")
    # Anything that names a file (an existing one, a path, an .xml name) is read as a file,
    # so a missing file is reported as missing rather than as an unknown host.
    if path.is_file() or not sep or "/" in spec or spec.lower().endswith(".xml"):
        return read_xml(path)
    try:
        host, port_number = parse_server(spec)
    except ValueError:
        raise HistoryError(f"history {spec!r}: not a file, sqlite:PATH or HOST:PORT") from None
    return retrieve_live(host, port_number, whiteboards=whiteboards, timeout=timeout)


def _sorted(messages: Sequence[Message]) -> tuple[Message, ...]:
    """Order oldest first by receivedTime (else postedTime); the sort is stable."""
    return tuple(sorted(messages, key=lambda m: t.us if (t := m.received or m.posted) else -1))


def read_xml(path: str | Path) -> History:
    """Read an `<objectcollection>` of messages from a file (the retrieve result format)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise HistoryError(f"history {path}: cannot read: {exc.strerror}") from None
    try:
        # The hardened parser (OA-SEC-1/2), then the lenient reader of retrieve results.
        root = parse_xml(data, XmlLimits(max_bytes=MAX_HISTORY_BYTES))
        messages = read_message_collection(root)
    except OpenAIRError as exc:
        raise HistoryError(f"history {path}: {exc}") from None
    return History(source=str(path), messages=_sorted(messages))


def read_sqlite(path: str) -> History:
    """Read every stored copy of a reference server's SQLite store, read-only."""
    if not path or not Path(path).is_file():
        raise HistoryError(f"history sqlite:{path}: no such file")
    try:
        db = sqlite3.connect(f"file:{Path(path).resolve()}?mode=ro", uri=True)
    except sqlite3.Error as exc:
        raise HistoryError(f"history sqlite:{path}: {exc}") from None
    try:
        rows = db.execute("SELECT xml, binary FROM messages ORDER BY whiteboard, wbid").fetchall()
    except sqlite3.Error as exc:
        raise HistoryError(f"history sqlite:{path}: not a reference server store: {exc}") from None
    finally:
        db.close()
    messages: list[Message] = []
    broken = 0
    for xml, binary in rows:
        msg = _decode_row(bytes(xml), bytes(binary))
        if msg is None:
            broken += 1
        else:
            messages.append(msg)
    notes = (f"{broken} stored rows did not decode and were skipped",) if broken else ()
    return History(source=f"sqlite:{path}", messages=_sorted(messages), notes=notes)


def _decode_row(xml: bytes, binary: bytes) -> Message | None:
    """Decode one stored row as the store wrote it (its XML, then its chunks concatenated)."""
    try:
        sizes = binary_sizes(xml)
        if sum(sizes) != len(binary):
            return None
        chunks, pos = [], 0
        for size in sizes:
            chunks.append(binary[pos : pos + size])
            pos += size
        return decode_message(xml, tuple(chunks))
    except (OpenAIRError, ValueError):
        return None


def retrieve_live(
    host: str, port: int, *, whiteboards: Sequence[str] = (), timeout: float = 10.0
) -> History:
    """Retrieve every stored message of a running server's whiteboards."""
    source = f"{host}:{port}"
    try:
        messages, notes = asyncio.run(_retrieve(host, port, tuple(whiteboards), timeout))
    except (OSError, ConnectionClosedError) as exc:
        raise HistoryConnectError(f"history {source}: cannot connect: {exc}") from None
    except OpenAIRError as exc:
        raise HistoryError(f"history {source}: {exc}") from None
    return History(source=source, messages=_sorted(messages), notes=tuple(notes))


async def _retrieve(
    host: str, port: int, named: tuple[str, ...], timeout: float
) -> tuple[list[Message], list[str]]:
    module = Module(
        CLIENT_NAME,
        host,
        port,
        bind=False,
        reconnect=False,
        keepalive=None,
        request_timeout=timeout,
    )
    messages: list[Message] = []
    notes: list[str] = []
    async with module:
        boards = named or await _whiteboard_names(module) or DEFAULT_WHITEBOARDS
        for board in boards:
            spec = RetrieveSpec(whiteboard=board, pattern="*", latest=0)  # OA-RET-4: 0 = all
            try:
                messages.extend(await module.retrieve(spec, to=board))
            except FailedReplyError as exc:
                notes.append(f"whiteboard {board}: retrieve refused ({exc})")
    return messages, notes


async def _whiteboard_names(module: Module) -> tuple[str, ...]:
    """Ask CNS for STATUS and return the whiteboards its counters name (maybe none)."""
    request = Message(type="STATUS", sender=module.name, to="CNS")
    try:
        reply = await module.request(request)
        entries = parse_dictionary(reply.content).entries if reply.content.strip() else ()
    except OpenAIRError:  # a server without STATUS counters (Psyclone): use the defaults
        return ()
    names: dict[str, None] = {}
    for key, _ in entries:
        if key.startswith("whiteboards.") and key.endswith(".count"):
            names[key[len("whiteboards.") : -len(".count")]] = None
    return tuple(names)


def history_of_recording(path: str) -> History:
    """Return a recording's messages as an ontology history (oldest first); raise HistoryError."""
    from openair_recording import messages_of  # lazily: only this source needs it

    try:
        records, reader = messages_of(path)
    except OSError as exc:
        raise HistoryError(f"recording {path}: cannot read: {exc.strerror}") from None
    except OpenAIRError as exc:
        raise HistoryError(f"recording {path}: not a readable recording: {exc}") from None
    ordered = sorted(records, key=lambda r: r.time_us)  # stable: file order within a time
    return History(
        source=path, messages=tuple(r.message for r in ordered), notes=tuple(reader.warnings)
    )
