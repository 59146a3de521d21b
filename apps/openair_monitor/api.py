"""The monitor's HTTP surface: pages, static files and the JSON API under /api/.

Read-only by default. `POST /api/post` posts a message through the router exactly as a
client's post is handled (the same `Router.handle`, the same wakeups), and only when the
server runs with `--monitor-post`, from an address in `--monitor-host` (loopback by default),
with a JSON body (`Content-Type: application/json`, which a cross-site form cannot send
without a CORS preflight this server never grants) and, when the browser names its `Origin`,
from a page of this server. The endpoints are documented in docs/monitor-api.md.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import json
import re
import time
import urllib.parse
from collections.abc import Callable
from typing import TYPE_CHECKING

from openair.protocol.codec import decode_message, encode_message
from openair.protocol.errors import OpenAIRError
from openair.protocol.message import MAX_PRIORITY, MIN_PRIORITY, Message
from openair.protocol.times import AirTime
from openair.protocol.types import validate_type
from openair_monitor import views
from openair_monitor.http import EventStream, HttpError, Request, Response, error_response
from openair_monitor.messages import MessageFilter
from openair_monitor.sse import TOPICS

if TYPE_CHECKING:
    from openair_monitor.core import Monitor

__all__ = ["respond"]

_PAGES = {
    "/": "index.html",
    "/whiteboard": "whiteboard.html",
    "/module": "module.html",
    "/graph": "graph.html",
    "/post": "post.html",
}
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".svg": "image/svg+xml",
}
_PAGE_HEADERS = (
    (
        "Content-Security-Policy",
        "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
        "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'self'",
    ),
    ("X-Content-Type-Options", "nosniff"),
    ("Referrer-Policy", "no-referrer"),
    ("Cache-Control", "no-cache"),
)
_API_HEADERS = (("Cache-Control", "no-store"), ("X-Content-Type-Options", "nosniff"))
_READ = ("GET", "HEAD")
_MAX_LIMIT = 1000
_POST_SENDER = "Monitor"  # `from` of a post that names none
_COMMANDS = frozenset({"AIR.Subscribe"})  # not a post: it would re-register another module


@functools.cache
def _static() -> dict[str, tuple[bytes, str]]:
    """Return the static files by name, read once from the package data."""
    files: dict[str, tuple[bytes, str]] = {}
    for entry in importlib.resources.files("openair_monitor").joinpath("static").iterdir():
        suffix = "." + entry.name.rsplit(".", 1)[-1]
        if entry.is_file() and suffix in _TYPES:
            files[entry.name] = (entry.read_bytes(), _TYPES[suffix])
    return files


def _json(obj: object, status: int = 200) -> Response:
    body = json.dumps(obj, separators=(",", ":"), ensure_ascii=False).encode()
    return Response(status=status, body=body, headers=_API_HEADERS)


def _file(name: str) -> Response:
    found = _static().get(name)
    if found is None:
        raise HttpError(404, "no such file")
    body, kind = found
    return Response(body=body, content_type=kind, headers=_PAGE_HEADERS)


def _not_allowed(allowed: tuple[str, ...]) -> Response:
    response = error_response(HttpError(405, "method not allowed"), close=False)
    return dataclasses.replace(response, headers=(("Allow", ", ".join(allowed)),))


def _segments(path: str) -> list[str]:
    """Split a path into decoded segments; refuse bad percent-encoding."""
    try:
        return [urllib.parse.unquote(s, errors="strict") for s in path.split("/")[1:]]
    except UnicodeDecodeError:
        raise HttpError(400, "the path is not valid UTF-8") from None


def _query(request: Request) -> dict[str, str]:
    """Return the query's parameters (the first value of each)."""
    try:
        parsed = urllib.parse.parse_qs(
            request.query, keep_blank_values=True, max_num_fields=32, errors="strict"
        )
    except (ValueError, UnicodeDecodeError):
        raise HttpError(400, "malformed query string") from None
    return {k: v[0] for k, v in parsed.items()}


def _int_param(
    params: dict[str, str], name: str, default: int | None, *, low: int = 1, high: int = 2**62
) -> int | None:
    text = params.get(name, "")
    if not text:
        return default
    if not text.isascii() or not text.isdigit() or not low <= int(text) <= high:
        raise HttpError(400, f"{name} must be a whole number from {low} to {high}")
    return int(text)


def _filter(params: dict[str, str], whiteboard: str) -> MessageFilter:
    try:
        return MessageFilter.checked(
            whiteboard=whiteboard,
            pattern=params.get("pattern", ""),
            sender=params.get("from", ""),
            content=params.get("content", ""),
        )
    except OpenAIRError as err:  # OA-MATCH-7: an invalid pattern is refused, not guessed
        raise HttpError(400, str(err.detail or err)) from None


def respond(mon: Monitor, request: Request, peer: str) -> Response | EventStream:
    """Answer one request: a page, a static file or an API endpoint."""
    path = request.path
    if path.startswith("/api/") or path == "/api":
        return _api(mon, request, peer, _segments(path)[1:])
    if request.method not in _READ:
        return _not_allowed(_READ)
    if path in _PAGES:
        return _file(_PAGES[path])
    if path == "/favicon.ico":
        return _file("favicon.svg")  # browsers ask for it before reading the page's <link>
    if path.startswith("/static/"):
        return _file(path.removeprefix("/static/"))
    raise HttpError(404, "no such page")


Handler = Callable[["Monitor", Request, str, list[str]], Response | EventStream]


def _api(mon: Monitor, request: Request, peer: str, parts: list[str]) -> Response | EventStream:
    parts = [p for p in parts if p] or [""]
    route = "/".join(["", *(p.replace("/", "%2F") for p in parts)])  # a decoded / stays inside
    for pattern, methods, handler in _ROUTES:
        if pattern.fullmatch(route):
            if request.method not in methods:
                return _not_allowed(methods)
            return handler(mon, request, peer, parts[1:])
    raise HttpError(404, "no such endpoint")


def _index(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    return _json(
        {
            "endpoints": [
                "/api/overview",
                "/api/whiteboards",
                "/api/whiteboards/{name}/messages?pattern=&from=&content=&limit=&before=",
                "/api/messages/{whiteboard}/{wbid or id}",
                "/api/messages/{whiteboard}/{wbid or id}/attachments/{n}",
                "/api/modules",
                "/api/modules/{name}",
                "/api/streams",
                "/api/graph",
                "/api/events?topics=messages,overview,graph&wb=&pattern=&from=&content=&since=",
                "POST /api/post",
            ]
        }
    )


def _overview(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    return _json(mon.overview())


def _whiteboards(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    return _json({"whiteboards": views.whiteboards(mon, mon.now())})


def _messages(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    params = _query(request)
    flt = _filter(params, args[0])
    limit = _int_param(params, "limit", 100, high=_MAX_LIMIT) or 100
    before = _int_param(params, "before", None)
    found = views.whiteboard_messages(mon, args[0], flt, limit=limit, before=before)
    if found is None:
        raise HttpError(404, f"no whiteboard {args[0]!r}")
    return _json(found)


def _message(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    found = views.find_message(mon, args[0], args[1])
    if found is None:
        raise HttpError(404, f"no message {args[1]!r} on {args[0]!r}")
    return _json(found)


def _attachment(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    """Download attachment n (from 1) of a stored message as bytes (OA-WB-13)."""
    msg = views.stored_message(mon, args[0], args[1])
    index = int(args[3]) if args[3].isdigit() and len(args[3]) < 9 else 0
    if msg is None or not 1 <= index <= len(msg.binary):
        raise HttpError(404, f"no attachment {args[3]!r} of {args[1]!r} on {args[0]!r}")
    name = f"{args[0]}-{msg.wbid}-{index}.bin".replace('"', "")
    disposition = ("Content-Disposition", f'attachment; filename="{name}"')
    return Response(
        body=msg.binary[index - 1],
        content_type="application/octet-stream",
        headers=(*_API_HEADERS, disposition),
    )


def _modules(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    return _json({"modules": views.modules(mon, mon.now())})


def _module(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    found = views.module_detail(mon, args[0], mon.now())
    if found is None:
        raise HttpError(404, f"no module {args[0]!r}")
    return _json(found)


def _streams(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    return _json({"streams": views.stream_infos(mon, mon.now())})


def _graph(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    return _json(mon.graph())


def _events(mon: Monitor, request: Request, peer: str, args: list[str]) -> EventStream:
    params = _query(request)
    topics = frozenset(t for t in params.get("topics", "messages,overview").split(",") if t)
    if not topics or not topics <= TOPICS:
        raise HttpError(400, f"topics must be among {', '.join(sorted(TOPICS))}")
    board = params.get("wb", "")
    if board and mon.server.whiteboard(board) is None:
        raise HttpError(404, f"no whiteboard {board!r}")
    flt = _filter(params, board)
    since = _int_param(params, "since", None, low=0)
    if len(mon.broadcaster.streams) >= mon.limits.max_streams:
        raise HttpError(503, "too many event streams")
    return EventStream(on_open=lambda conn: mon.broadcaster.open(conn, topics, flt, since))


# -- posting -------------------------------------------------------------------------------------


def _check_poster(mon: Monitor, request: Request, peer: str) -> None:
    if not mon.post_enabled:
        raise HttpError(403, "posting is disabled (start the server with --monitor-post)")
    if peer not in mon.post_hosts:
        raise HttpError(403, f"posting is not allowed from {peer}")
    origin = request.header("origin")
    if origin is not None and urllib.parse.urlsplit(origin).netloc != request.header("host"):
        raise HttpError(403, "a page of another site may not post")
    kind = (request.header("content-type") or "").split(";")[0].strip().lower()
    if kind != "application/json":
        raise HttpError(415, "the body must be application/json")


def _text(fields: dict[str, object], name: str, default: str = "") -> str:
    value = fields.get(name, default)
    if value is None:
        return default
    if not isinstance(value, str):
        raise HttpError(400, f"{name} must be a string")
    return value


def _priority(fields: dict[str, object]) -> float | None:
    value = fields.get("priority")
    if value is None or value == "":
        return None
    try:
        priority = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise HttpError(400, "priority must be a number") from None
    if not MIN_PRIORITY <= priority <= MAX_PRIORITY:  # OA-MSG-6
        raise HttpError(400, f"priority must be {MIN_PRIORITY} to {MAX_PRIORITY}")
    return priority


def _post_message(mon: Monitor, fields: dict[str, object], now_ns: int) -> Message:
    """Build the post a client would send, and pass it through the codec both ways."""
    to = _text(fields, "to")
    if mon.server.whiteboard(to) is None:
        raise HttpError(400, f"to must name a whiteboard, not {to!r}")
    kind = _text(fields, "type").strip()
    if kind in _COMMANDS:
        raise HttpError(400, f"{kind} is a command, not a post")
    xml = fields.get("xml", False) is True
    try:
        msg = Message(
            type=validate_type(kind),  # OA-TYPE-1
            sender=_text(fields, "from").strip() or _POST_SENDER,
            to=to,
            cc=";".join(n.strip() for n in re.split(r"[;,]", _text(fields, "cc")) if n.strip()),
            priority=_priority(fields),
            content=_text(fields, "content"),
            content_is_xml=xml,
            language="xml" if xml else "",
            posted=AirTime.from_ns(now_ns),
        )
        return decode_message(encode_message(msg))  # exactly what a client could have sent
    except OpenAIRError as err:
        raise HttpError(400, str(err.detail or err)) from None


def _post(mon: Monitor, request: Request, peer: str, args: list[str]) -> Response:
    _check_poster(mon, request, peer)
    try:
        fields = json.loads(request.body)
    except (ValueError, UnicodeDecodeError):
        raise HttpError(400, "the body is not JSON") from None
    if not isinstance(fields, dict):
        raise HttpError(400, "the body must be a JSON object")
    now_ns = time.time_ns()
    msg = _post_message(mon, fields, now_ns)
    server = mon.server
    outcome = server.inject(msg, received_ns=now_ns)
    reply = outcome.replies[0] if outcome.replies else None
    accepted = reply is not None and reply.type == "RECEIVE_ACCEPT"
    board = server.whiteboard(msg.to)
    body = {
        "accepted": accepted,
        "id": msg.id,
        "whiteboard": msg.to,
        "wbid": board.next_wbid - 1 if accepted and board is not None else None,
        "reply": None if reply is None else {"type": reply.type, "content": reply.content},
    }
    return _json(body, 200 if accepted else 422)


_NAME = r"/[^/]+"
_ROUTES: tuple[tuple[re.Pattern[str], tuple[str, ...], Handler], ...] = (
    (re.compile(r"/"), _READ, _index),
    (re.compile(r"/overview"), _READ, _overview),
    (re.compile(r"/whiteboards"), _READ, _whiteboards),
    (re.compile(rf"/whiteboards{_NAME}/messages"), _READ, _messages),
    (re.compile(rf"/messages{_NAME}{_NAME}"), _READ, _message),
    (re.compile(rf"/messages{_NAME}{_NAME}/attachments/[0-9]+"), _READ, _attachment),
    (re.compile(r"/modules"), _READ, _modules),
    (re.compile(rf"/modules{_NAME}"), _READ, _module),
    (re.compile(r"/streams"), _READ, _streams),
    (re.compile(r"/graph"), _READ, _graph),
    (re.compile(r"/events"), _READ, _events),
    (re.compile(r"/post"), ("POST",), _post),
)
