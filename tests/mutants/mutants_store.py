"""Mutants of storing and retrieving (spec sections 7 and 9).

Stored-copy mutants change the slots `Whiteboard.store_post` sets (through `derive` as the
whiteboard module imports it); retrieve mutants wrap the history scan `select` (both retrieve
paths), the content glob, the request reader `openair.server.core.retrieve.parse_request` and
`prepare_retrieve` as the router imports it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest
from lxml import etree
from mutants_core import Fn, defer, mutant, wrap, wrap_select

import openair.protocol.objects
from openair.protocol.content import ContentMatch, RetrieveSpec
from openair.protocol.errors import RetrieveInvalidError
from openair.protocol.message import Message
from openair.protocol.objects import parse_content
from openair.protocol.xmlsafe import local_name
from openair.server.core import commands, retrieve, router, whiteboard
from openair.server.core.router import Outcome, Router
from openair.server.core.whiteboard import Whiteboard

# --- acknowledging and storing a post (7.3, 7.4) -------------------------------------------------


@mutant(
    "ack-before-store",
    "RECEIVE_ACCEPT at once; storing (and refusing) happens after the next request",
    "OA-WB-3",
)
def _ack_before_store(mp: pytest.MonkeyPatch) -> None:
    def ack(self: Router, board: Whiteboard, msg: Message, *times: int) -> Outcome:
        now_ns = times[-1]
        reply = commands.reply(msg, "RECEIVE_ACCEPT", sender=board.name, now_ns=now_ns)
        return Outcome(replies=(reply,))

    defer(mp, "_post", ack, requests=1)


def _stored_copy_patch(mp: pytest.MonkeyPatch, change: Callable[[dict[str, Any]], None]) -> None:
    """Change the slots `Whiteboard.store_post` sets on a stored copy."""

    def make(original: Fn) -> Fn:
        def derive(msg: Message, **changes: Any) -> Message:
            if "wbid" in changes:  # only store_post derives with a wbid
                change(changes)
            result: Message = original(msg, **changes)
            return result

        return derive

    wrap(mp, whiteboard, "derive", make)


@mutant("received-time-missing", "stored copies carry no receivedTime", "OA-TIME-3")
def _received_missing(mp: pytest.MonkeyPatch) -> None:
    _stored_copy_patch(mp, lambda ch: ch.update(received=None))


@mutant("stored-slot-missing", "stored copies carry no stored slot", "OA-WB-4")
def _stored_missing(mp: pytest.MonkeyPatch) -> None:
    _stored_copy_patch(mp, lambda ch: ch.update(stored=""))


@mutant("wbid-constant", "every stored copy gets wbid 1", "OA-WB-5")
def _wbid_constant(mp: pytest.MonkeyPatch) -> None:
    _stored_copy_patch(mp, lambda ch: ch.update(wbid=1))


@mutant("unknown-slots-dropped", "stored copies lose the slots it does not know", "OA-MSG-5")
def _extras_dropped(mp: pytest.MonkeyPatch) -> None:
    _stored_copy_patch(mp, lambda ch: ch.update(extras=()))


@mutant("posted-time-rewritten", "stored copies get postedTime = receivedTime", "OA-TIME-4")
def _posted_rewritten(mp: pytest.MonkeyPatch) -> None:
    _stored_copy_patch(mp, lambda ch: ch.update(posted=ch["received"]))


@mutant(
    "maxcount-off-by-one",
    "a whiteboard holds maxcount + 1 messages",
    "OA-WB-6",
    cases=("WB-004",),
    slow=True,
)
def _maxcount(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def __init__(self: Whiteboard, *args: Any, **kwargs: Any) -> None:
            original(self, *args, **kwargs)
            self.maxcount += 1

        return __init__

    wrap(mp, Whiteboard, "__init__", make)


@mutant("type-invalid-accepted", "posts with an invalid type are stored", "OA-TYPE-3")
def _type_invalid(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(router, "validate_type", lambda *args, **kwargs: None)


@mutant("noreply-answered", "noreply posts are answered anyway", "OA-MSG-15")
def _noreply_answered(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def __init__(self: Router, *args: Any, **kwargs: Any) -> None:
            original(self, *args, **kwargs)
            self._noreply = False

        return __init__

    wrap(mp, Router, "__init__", make)


# --- retrieve (9) ------------------------------------------------------------------------


def _retrieve_patch(
    mp: pytest.MonkeyPatch,
    spec_change: Callable[[RetrieveSpec], RetrieveSpec],
    result_change: Callable[[RetrieveSpec, list[Message], int], list[Message]],
) -> None:
    """Run every retrieve unlimited with a changed spec, change the result, then apply latest."""

    def make(original: Fn) -> Fn:
        def select_(
            messages: Any, spec: RetrieveSpec, *, now_ns: int, **bounds: Any
        ) -> list[Message]:
            changed = replace(spec_change(spec), latest=0)
            found = original(messages, changed, now_ns=now_ns, **bounds)
            found = result_change(spec, found, now_ns)
            return found[: spec.latest] if spec.latest else found

        return select_

    wrap_select(mp, make)


@mutant("retrieve-oldest-first", "retrieve results come oldest first", "OA-RET-6")
def _oldest_first(mp: pytest.MonkeyPatch) -> None:
    _retrieve_patch(mp, lambda s: s, lambda s, found, now: found[::-1])


@mutant("lastmsec-by-posted", "lastmsec selects by postedTime", "OA-RET-5")
def _lastmsec_posted(mp: pytest.MonkeyPatch) -> None:
    def keep(spec: RetrieveSpec, found: list[Message], now_ns: int) -> list[Message]:
        if not spec.lastmsec:
            return found
        lower = now_ns // 1_000_000 - spec.lastmsec
        return [m for m in found if m.posted is not None and m.posted.ms >= lower]

    _retrieve_patch(mp, lambda s: replace(s, lastmsec=None), keep)


@mutant("until-exclusive", "untilTime is an exclusive bound", "OA-RET-9")
def _until_exclusive(mp: pytest.MonkeyPatch) -> None:
    def keep(spec: RetrieveSpec, found: list[Message], now_ns: int) -> list[Message]:
        until = spec.until_time
        if until is None:
            return found
        return [m for m in found if m.received is not None and m.received.us < until.us]

    _retrieve_patch(mp, lambda s: s, keep)


def _glob_patch(
    mp: pytest.MonkeyPatch, make_glob: Callable[[Fn, str], Callable[[str], bool]]
) -> None:
    original = whiteboard.content_glob
    mp.setattr(whiteboard, "content_glob", lambda pattern: make_glob(original, pattern))


@mutant("content-glob-case-insensitive", "the content glob ignores case", "OA-RET-8")
def _glob_case(mp: pytest.MonkeyPatch) -> None:
    def make_glob(original: Fn, pattern: str) -> Callable[[str], bool]:
        inner = original(pattern.lower())
        return lambda text: bool(inner(text.lower()))

    _glob_patch(mp, make_glob)


@mutant("content-glob-substring", "the content glob matches anywhere in the text", "OA-RET-8")
def _glob_substring(mp: pytest.MonkeyPatch) -> None:
    _glob_patch(mp, lambda original, pattern: original(f"*{pattern}*"))


Specs = tuple[RetrieveSpec, ...]


def _request_patch(mp: pytest.MonkeyPatch, change: Callable[[Message, Specs], Specs]) -> None:
    def make(original: Fn) -> Fn:
        def parse_request(msg: Message) -> Specs:
            return change(msg, original(msg))

        return parse_request

    wrap(mp, retrieve, "parse_request", make)


def _has_latest(el: etree._Element) -> bool:
    attrs = {str(k).lower() for k in el.attrib}
    return "latest" in attrs or any(local_name(c) == "latest" for c in el if isinstance(c.tag, str))


@mutant("latest-default-0", "a retrieve without latest returns every match", "OA-RET-4")
def _latest_default(mp: pytest.MonkeyPatch) -> None:
    def change(msg: Message, specs: Specs) -> Specs:
        roots = parse_content(msg.content, RetrieveInvalidError)
        els = roots if local_name(roots[0]) == "retrieve" else [*roots[0]]
        els = [el for el in els if isinstance(el.tag, str) and local_name(el) == "retrieve"]
        if len(els) != len(specs):
            return specs
        pairs = zip(specs, els, strict=True)
        return tuple(s if _has_latest(el) else replace(s, latest=0) for s, el in pairs)

    _request_patch(mp, change)


@mutant("retrieves-reversed", "AIR.Retrieves concatenates its retrieves last first", "OA-RET-12")
def _retrieves_reversed(mp: pytest.MonkeyPatch) -> None:
    _request_patch(mp, lambda msg, specs: specs[::-1])


class _Fallback(dict[str, Whiteboard]):
    """A whiteboard table that answers an unknown name with the addressed whiteboard."""

    fallback: Whiteboard

    def get(self, key: str, default: Any = None) -> Any:
        return super().get(key, self.fallback)


@mutant(
    "retrieve-unknown-board-ok",
    "a retrieve from an unknown whiteboard reads the addressed one",
    "OA-RET-11",
)
def _unknown_board(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def answer(msg: Message, addressee: Whiteboard, boards: Any, **kwargs: Any) -> Any:
            table = _Fallback(boards)
            table.fallback = addressee
            result = original(msg, addressee, table, **kwargs)
            return result

        return answer

    wrap(mp, router, "prepare_retrieve", make)


@mutant("sender-case-insensitive", "a retrieve's sender matches in any case", "OA-RET-3")
def _sender_case(mp: pytest.MonkeyPatch) -> None:
    def keep(spec: RetrieveSpec, found: list[Message], now_ns: int) -> list[Message]:
        wanted = spec.sender.lower()
        return [m for m in found if m.sender.lower() == wanted] if wanted else found

    _retrieve_patch(mp, lambda s: replace(s, sender=""), keep)


class _Folded(dict[str, Whiteboard]):
    """A whiteboard table that finds names in any case."""

    def get(self, key: str, default: Any = None) -> Any:
        return next((wb for name, wb in self.items() if name.lower() == key.lower()), default)


@mutant(
    "board-name-case-insensitive", "a retrieve's from names whiteboards in any case", "OA-WB-10"
)
def _board_case(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def answer(msg: Message, addressee: Whiteboard, boards: Any, **kwargs: Any) -> Any:
            result = original(msg, addressee, _Folded(boards), **kwargs)
            return result

        return answer

    wrap(mp, router, "prepare_retrieve", make)


@mutant("commands-stored", "AIR.Subscribe and AIR.Retrieve are stored like posts", "OA-WB-11")
def _commands_stored(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _to_whiteboard(self: Router, board: Whiteboard, msg: Message, *times: int) -> Outcome:
            if msg.type in ("AIR.Subscribe", "AIR.Retrieve", "AIR.Retrieves"):
                board.store_post(msg, times[0])
            result: Outcome = original(self, board, msg, *times)
            return result

        return _to_whiteboard

    wrap(mp, Router, "_to_whiteboard", make)


@mutant(
    "same-id-dropped", "a post whose id was stored before is acknowledged, not stored", "OA-MSG-8"
)
def _same_id(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _post(self: Router, board: Whiteboard, msg: Message, *times: int) -> Outcome:
            seen: set[str] = self.__dict__.setdefault("_mutant_ids", set())
            if msg.id in seen:
                ack = commands.reply(msg, "RECEIVE_ACCEPT", sender=board.name, now_ns=times[-1])
                return Outcome(replies=(ack,))
            seen.add(msg.id)
            result: Outcome = original(self, board, msg, *times)
            return result

        return _post

    wrap(mp, Router, "_post", make)


@mutant("type-bytes-off-by-one", "a type of max-type-bytes is refused", "OA-TYPE-4")
def _type_bytes(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def validate_type(type_: str, *, max_bytes: int | None, **kwargs: Any) -> None:
            original(type_, max_bytes=max_bytes - 1 if max_bytes else max_bytes, **kwargs)

        return validate_type

    wrap(mp, router, "validate_type", make)


@mutant("retrieve-bad-pattern-accepted", "retrieves with invalid patterns are served", "OA-MATCH-7")
def _retrieve_bad_pattern(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(openair.protocol.objects, "validate_pattern", lambda *args, **kwargs: None)
    mp.setattr(openair.protocol.objects, "is_valid_pattern", lambda *args, **kwargs: True)


@mutant(
    "bad-retrieve-reads-all", "an invalid retrieve spec returns the newest message", "OA-RET-10"
)
def _bad_retrieve(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def parse_request(msg: Message) -> Specs:
            try:
                specs: Specs = original(msg)
            except RetrieveInvalidError:
                return (RetrieveSpec(),)
            return specs

        return parse_request

    wrap(mp, retrieve, "parse_request", make)


@mutant("contentmatch-ignored", "contentmatch='xml' is read as text", "OA-RET-13")
def _contentmatch(mp: pytest.MonkeyPatch) -> None:
    text = ContentMatch.TEXT
    _retrieve_patch(mp, lambda s: replace(s, contentmatch=text), lambda s, found, now: found)
