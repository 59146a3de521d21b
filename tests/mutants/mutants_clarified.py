"""Mutants of the rules spec 1.0-draft.5 made precise (issue #25), one deliberate fault each.

Each is the one-line slip an implementer reading the older, looser text could make: content
globs matched against the XML as stored or with spaced text, type validity by a runtime's
"printable" test, a pattern limit one byte short, star-less patterns handed to a regex engine,
a 32-bit wbid, a RESOLVE port nothing listens on, a pending callback connection forgotten at
BIND, no fallback from an unreachable listening port, and binding again treated as a takeover.
Seams are server-only names (as mutants_core.py requires): what server modules import.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

import openair.protocol.contentmatch
import openair.protocol.registration
import openair.protocol.types
from openair.protocol.content import TcpLocation
from openair.protocol.contentmatch import _text, _wrapper
from openair.protocol.errors import MessageInvalidError, TypeInvalidError
from openair.protocol.matching import ascii_fold
from openair.protocol.message import Message
from openair.server.aio import delivery
from openair.server.core import commands, router, router_commands, sessions, whiteboard
from openair.server.core.router import Outcome, Router

# --- retrieve content (9.2) ----------------------------------------------------------------------


@mutant(
    "xml-content-as-stored",
    "contentmatch='xml' globs see the content as stored (indentation kept), not OA-RET-17's text",
    "OA-RET-17",
    "OA-RET-13",
)
def _xml_as_stored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(whiteboard, "xml_text_of", lambda m: m.content)


@mutant(
    "text-content-spaced",
    "the text content joins the kept text runs with a space ('x y' for <a>x</a> <b>y</b>)",
    "OA-RET-18",
    "OA-RET-8",
)
def _text_spaced(mp: pytest.MonkeyPatch) -> None:
    def spaced(content: str) -> str:
        out: list[str] = []
        _text(_wrapper(content), out)
        return " ".join(out)

    mp.setattr(openair.protocol.contentmatch, "text_content", spaced)


# --- types and patterns (section 5) --------------------------------------------------------------


@mutant(
    "type-validity-isprintable",
    "posted types are judged by str.isprintable(), which also refuses unassigned code points",
    "OA-TYPE-5",
)
def _isprintable(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def validate(type_: str, **limits: Any) -> str:
            if not type_.isprintable():
                raise TypeInvalidError(f"type {type_!r} contains a non-printable character")
            result: str = original(type_, **limits)
            return result

        return validate

    wrap(mp, router, "validate_type", make)


@mutant(
    "pattern-limit-254",
    "registrations refuse a trigger pattern of 255 bytes (a limit one byte short)",
    "OA-MATCH-9",
)
def _pattern_limit(mp: pytest.MonkeyPatch) -> None:
    def validate(pattern: str) -> str:
        return openair.protocol.types.validate_pattern(pattern, max_bytes=254)

    # openair.protocol.registration reads registrations; only the server does that in the suite's
    # tests.
    mp.setattr(openair.protocol.registration, "validate_pattern", validate)


@mutant(
    "starless-pattern-as-regex",
    "a retrieve pattern without '*' is compared as a regular expression ([A&&B] is a class)",
    "OA-MATCH-10",
)
def _regex_patterns(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def matcher(pattern: str) -> Callable[[str], bool]:
            if "*" in pattern:
                return original(pattern)  # type: ignore[no-any-return]

            def matches(type_: str) -> bool:
                try:
                    with warnings.catch_warnings():  # `[A&&B]` warns of a future set operation
                        warnings.simplefilter("ignore", FutureWarning)
                        return re.fullmatch(ascii_fold(pattern), ascii_fold(type_)) is not None
                except re.error:
                    return False

            return matches

        return matcher

    wrap(mp, whiteboard, "matcher", make)


# --- the envelope (3.2) --------------------------------------------------------------------------


@mutant(
    "wbid-int32",
    "a post whose wbid slot does not fit a signed 32-bit integer is refused MESSAGE_INVALID",
    "OA-MSG-13",
)
def _wbid_int32(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def post(self: Router, board: Any, msg: Message, received_ns: int, now_ns: int) -> Outcome:
            if msg.wbid is not None and msg.wbid >= 2**31:
                err = MessageInvalidError(f"wbid {msg.wbid} out of range")
                return Outcome(replies=(self._error(msg, err, board.name, now_ns),))
            result: Outcome = original(self, board, msg, received_ns, now_ns)
            return result

        return post

    wrap(mp, Router, "_post", make)


# --- reaching a module (6.3-6.6) -----------------------------------------------------------------


@mutant(
    "resolve-wrong-port",
    "RESOLVE_SUCCESS names a port one above the one the component answers on",
    "OA-SESS-34",
)
def _resolve_port(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def encode(location: TcpLocation) -> str:
            result: str = original(replace(location, port=location.port + 1))
            return result

        return encode

    wrap(mp, router_commands, "encode_tcplocation", make)


@mutant(
    "pending-callback-dropped",
    "BIND forgets a callback connection opened before it (the module is never reached)",
    "OA-SESS-36",
)
def _pending_dropped(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def bind(self: sessions.Sessions, conn: Any, msg: Message, reg: Any) -> Any:
            self._pending.pop(msg.sender, None)
            return original(self, conn, msg, reg)

        return bind

    wrap(mp, sessions.Sessions, "bind", make)


@mutant(
    "listening-port-only",
    "a module with a listening port is never delivered to over its callback connection",
    "OA-DELIV-13",
)
def _port_only(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def callback_path(self: delivery.ModuleDelivery) -> Any:
            info = self._d.host.module_info(self.name)
            if info is not None and info.port > 0:
                return None
            return original(self)

        return callback_path

    wrap(mp, delivery.ModuleDelivery, "_callback_path", make)


@mutant(
    "rebind-is-takeover",
    "BIND again on the module's own primary connection is handled as a takeover",
    "OA-SESS-35",
)
def _rebind_takeover(mp: pytest.MonkeyPatch) -> None:
    def take_over(self: sessions.Sessions, old: sessions.ModuleInfo, conn: Any) -> tuple[Any, ...]:
        close: list[Any] = []
        if old.conn is not None:  # the same-connection check of OA-SESS-35 is gone
            names = self._primary.get(old.conn, [])
            if old.name in names:
                names.remove(old.name)
            close.append(old.conn)
        if old.callback is not None and old.callback != conn:
            self._callbacks.pop(old.callback, None)
            close.append(old.callback)
        return tuple(close)

    mp.setattr(sessions.Sessions, "_take_over", take_over)


# --- capabilities (15.1) -------------------------------------------------------------------------


@mutant(
    "limit-value-signed",
    "CAPABILITIES writes each limit value with a leading '+' (an integer, but not digits only)",
    "OA-CAP-1",
)
def _limit_signed(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def encode(caps: Any) -> str:
            result: str = original(caps)
            return re.sub(r'value="(\d+)"', r'value="+\1"', result)

        return encode

    wrap(mp, commands, "encode_capabilities", make)


@mutant(
    "switch-paths-in-flight",
    "a new callback connection is used at once, with deliveries unanswered on the listener",
    "OA-DELIV-12",
)
def _switch_in_flight(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(delivery.ModuleDelivery, "_busy_elsewhere", lambda self, conn: False)
