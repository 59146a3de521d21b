"""The monitor's JSON API over a recording (`openair monitor FILE`): read-only, no server.

The endpoints the live monitor serves for stored messages answer here from the recording, in
the same shapes (docs/monitor-api.md): `/api/overview` (the recording instead of the server),
`/api/whiteboards`, `/api/whiteboards/{name}/messages` with the same filters and paging,
`/api/messages/{whiteboard}/{wbid or id}` (wakeups unknown: a recording holds messages, not the
wakeups they caused) and its attachments, and `/api/streams` (the recorded samples). Live
endpoints (events, modules, graph, post) and the HTML pages are not served. HTTP is the monitor's
own connection class, with its limits.
"""

from __future__ import annotations

import json
import re
import urllib.parse
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from openair.protocol.errors import OpenAIRError
from openair.protocol.message import Message
from openair_monitor.http import HttpConnection, HttpError, HttpLimits, Request, Response
from openair_monitor.messages import MessageFilter, detail, summary
from openair_recording.fileformat import Header, MessageRecord, Record, SampleRecord

__all__ = ["RecordingMonitor"]

_HEADERS = (("Cache-Control", "no-store"), ("X-Content-Type-Options", "nosniff"))
_READ = ("GET", "HEAD")
_MAX_LIMIT = 1000
_ENDPOINTS = [
    "/api/overview",
    "/api/whiteboards",
    "/api/whiteboards/{name}/messages?pattern=&from=&content=&limit=&before=",
    "/api/messages/{whiteboard}/{wbid or id}",
    "/api/messages/{whiteboard}/{wbid or id}/attachments/{n}",
    "/api/streams",
]


def _json(obj: object, status: int = 200) -> Response:
    body = json.dumps(obj, separators=(",", ":"), ensure_ascii=False).encode()
    return Response(status=status, body=body, headers=_HEADERS)


def _query(request: Request) -> dict[str, str]:
    try:
        parsed = urllib.parse.parse_qs(
            request.query, keep_blank_values=True, max_num_fields=32, errors="strict"
        )
    except (ValueError, UnicodeDecodeError):
        raise HttpError(400, "malformed query string") from None
    return {k: v[0] for k, v in parsed.items()}


def _int_param(params: dict[str, str], name: str, default: int | None, high: int) -> int | None:
    text = params.get(name, "")
    if not text:
        return default
    if not text.isascii() or not text.isdigit() or not 1 <= int(text) <= high:
        raise HttpError(400, f"{name} must be a whole number from 1 to {high}")
    return int(text)


@dataclass(slots=True)
class RecordingMonitor:
    """An HttpApp (monitor/http.py) answering the JSON API from a recording's records."""

    path: str
    header: Header
    records: Sequence[Record]
    warnings: Sequence[str] = ()
    limits: HttpLimits = field(default_factory=HttpLimits)
    _boards: dict[str, list[Message]] = field(default_factory=dict)  # oldest first
    _conns: set[HttpConnection] = field(default_factory=set)

    def __post_init__(self) -> None:
        for name in self.header.whiteboards:
            self._boards.setdefault(name, [])
        for record in self.records:
            if isinstance(record, MessageRecord):
                msg = record.message
                self._boards.setdefault(msg.stored, []).append(msg)
        for msgs in self._boards.values():
            msgs.sort(key=lambda m: m.wbid if m.wbid is not None else -1)

    # -- HttpApp -----------------------------------------------------------------------------

    def opened(self, conn: HttpConnection) -> bool:
        if len(self._conns) >= self.limits.max_connections:
            return False
        self._conns.add(conn)
        return True

    def closed(self, conn: HttpConnection) -> None:
        self._conns.discard(conn)

    @property
    def connections(self) -> frozenset[HttpConnection]:
        """The open HTTP connections."""
        return frozenset(self._conns)

    def respond(self, request: Request, peer: str) -> Response:
        """Answer one read-only request."""
        if request.method not in _READ:
            raise HttpError(405, "a recording is read-only")
        try:
            parts = [urllib.parse.unquote(s, errors="strict") for s in request.path.split("/")]
        except UnicodeDecodeError:
            raise HttpError(400, "the path is not valid UTF-8") from None
        parts = [p for p in parts[1:] if p]
        if parts in ([], ["api"]):
            return _json({"recording": self.path, "endpoints": _ENDPOINTS})
        route = "/".join(["", *(p.replace("/", "%2F") for p in parts)])
        for pattern, handler in self._routes():
            if pattern.fullmatch(route):
                return handler(request, parts[2:])
        raise HttpError(404, "no such endpoint (a recording serves the message endpoints)")

    def _routes(self) -> tuple[tuple[re.Pattern[str], Callable[..., Response]], ...]:
        return (
            (re.compile(r"/api/overview"), self._overview),
            (re.compile(r"/api/whiteboards"), self._whiteboards),
            (re.compile(r"/api/whiteboards/[^/]+/messages"), self._messages),
            (re.compile(r"/api/messages/[^/]+/[^/]+"), self._message),
            (re.compile(r"/api/messages/[^/]+/[^/]+/attachments/[^/]+"), self._attachment),
            (re.compile(r"/api/streams"), self._streams),
        )

    # -- endpoints ---------------------------------------------------------------------------

    def _board_list(self) -> list[dict[str, object]]:
        return [
            {"name": name, "count": len(msgs),
             "first_ms": msgs[0].received.ms if msgs and msgs[0].received else None,
             "last_ms": msgs[-1].received.ms if msgs and msgs[-1].received else None}
            for name, msgs in self._boards.items()
        ]  # fmt: skip

    def _overview(self, request: Request, args: list[str]) -> Response:
        h = self.header
        samples = sum(1 for r in self.records if isinstance(r, SampleRecord))
        recording = {
            "file": self.path, "server": h.server, "recorder": h.recorder, "types": h.types,
            "started_ms": h.started_ns // 1_000_000, "extensions": list(h.extensions),
            "messages": len(self.records) - samples, "samples": samples,
            "warnings": list(self.warnings),
        }  # fmt: skip
        boards, streams = self._board_list(), self._stream_list()
        return _json({"recording": recording, "whiteboards": boards, "streams": streams})

    def _whiteboards(self, request: Request, args: list[str]) -> Response:
        return _json({"whiteboards": self._board_list()})

    def _board(self, name: str) -> list[Message]:
        msgs = self._boards.get(name)
        if msgs is None:
            raise HttpError(404, f"no whiteboard {name!r} in the recording")
        return msgs

    def _messages(self, request: Request, args: list[str]) -> Response:
        msgs = self._board(args[0])
        params = _query(request)
        try:
            flt = MessageFilter.checked(
                whiteboard=args[0], pattern=params.get("pattern", ""),
                sender=params.get("from", ""), content=params.get("content", ""),
            )  # fmt: skip
        except OpenAIRError as err:  # OA-MATCH-7: an invalid pattern is refused
            raise HttpError(400, str(err.detail or err)) from None
        limit = _int_param(params, "limit", 100, _MAX_LIMIT) or 100
        before = _int_param(params, "before", None, 2**62)
        accept = flt.compile()
        found: list[dict[str, object]] = []
        for msg in reversed(msgs):
            if len(found) >= limit:
                break
            if before is not None and (msg.wbid or 0) >= before:
                continue
            if accept(msg):
                found.append(summary(msg, None, None))
        return _json(
            {"whiteboard": args[0], "count": len(msgs), "truncated": False, "messages": found}
        )

    def _find(self, board: str, key: str) -> Message:
        wbid = int(key) if key.isdigit() else None
        for msg in self._board(board):
            if (wbid is not None and msg.wbid == wbid) or msg.id == key:
                return msg
        raise HttpError(404, f"no message {key!r} on {board!r} in the recording")

    def _message(self, request: Request, args: list[str]) -> Response:
        return _json(detail(self._find(args[0], args[1]), None))

    def _attachment(self, request: Request, args: list[str]) -> Response:
        msg = self._find(args[0], args[1])
        index = int(args[3]) if args[3].isdigit() and len(args[3]) < 9 else 0
        if not 1 <= index <= len(msg.binary):
            raise HttpError(404, f"no attachment {args[3]!r} of {args[1]!r} on {args[0]!r}")
        name = f"{args[0]}-{msg.wbid}-{index}.bin".replace('"', "")
        disposition = ("Content-Disposition", f'attachment; filename="{name}"')
        return Response(
            body=msg.binary[index - 1],
            content_type="application/octet-stream",
            headers=(*_HEADERS, disposition),
        )

    def _stream_list(self) -> list[dict[str, object]]:
        streams: dict[str, dict[str, object]] = {
            s["name"]: {**s, "samples": 0, "bytes": 0, "first_id": None, "last_id": None}
            for s in self.header.streams
        }
        for r in self.records:
            if isinstance(r, SampleRecord):
                entry = streams.setdefault(r.stream, {"name": r.stream, "samples": 0, "bytes": 0})
                entry["samples"] = int(str(entry["samples"])) + 1
                entry["bytes"] = int(str(entry["bytes"])) + len(r.sample.payload)
                if entry.get("first_id") is None:
                    entry["first_id"] = r.sample.id
                entry["last_id"] = r.sample.id
        return list(streams.values())

    def _streams(self, request: Request, args: list[str]) -> Response:
        return _json({"streams": self._stream_list()})
