"""The mutant record, the catalogue it is registered in, and the seams the mutants patch.

A mutant is a patch function over a `pytest.MonkeyPatch`; `Mutant.active()` applies it for the
duration of a block. Seams are chosen where only the server uses them: server classes and the
names server modules import, never `openair.protocol.codec`, `openair.protocol.framing` or
`openair.protocol.message`, which the suite's own harness shares with the server in this process. A
seam that disappears (renamed by a refactoring) makes `monkeypatch.setattr` raise, so the mutant
errors instead of silently testing nothing.

The preferred seam is the router's public surface: `Router.handle` / `connection_closed` return
an `Outcome` whose deliveries carry the wakeup messages; `outcome_patch` rewrites them there
(and drops a pre-written `wire` frame, so the adapter writes the changed message).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, fields, replace
from typing import Any

import pytest
from lxml import etree

from openair.protocol.message import Message
from openair.protocol.xmlsafe import local_name
from openair.server.core.router import Delivery, Outcome, Router

__all__ = [
    "CATALOGUE",
    "WAKEUP",
    "Fn",
    "Mutant",
    "Patch",
    "child",
    "defer",
    "mutant",
    "outcome_patch",
    "wakeup_object",
    "wakeup_patch",
    "with_message",
    "wrap",
]

Patch = Callable[[pytest.MonkeyPatch], None]
Fn = Callable[..., Any]
WAKEUP = "AIR.Instruct.Wakeup"


@dataclass(frozen=True, slots=True, kw_only=True)
class Mutant:
    """One deliberate fault: what it breaks, and the patch that puts it into the server.

    `limits` are ServerLimits fields the server needs for the catching cases to apply (as in
    tests/conformance/test_suite_reference.py's LIMITED); `cases` adds case globs to the
    selection its requirements give.
    """

    id: str
    description: str
    requirements: tuple[str, ...]
    patch: Patch
    limits: tuple[tuple[str, int], ...] = ()
    cases: tuple[str, ...] = ()
    slow: bool = False

    @contextlib.contextmanager
    def active(self) -> Iterator[None]:
        """Apply the fault for the duration of the block."""
        with pytest.MonkeyPatch.context() as mp:
            self.patch(mp)
            yield


CATALOGUE: dict[str, Mutant] = {}


def mutant(
    id: str,
    description: str,
    *requirements: str,
    limits: Mapping[str, int] | None = None,
    cases: tuple[str, ...] = (),
    slow: bool = False,
) -> Callable[[Patch], Patch]:
    """Register the decorated patch function as the mutant `id`."""

    def register(patch: Patch) -> Patch:
        if id in CATALOGUE:
            raise ValueError(f"duplicate mutant {id}")
        CATALOGUE[id] = Mutant(
            id=id,
            description=description,
            requirements=requirements,
            patch=patch,
            limits=tuple(sorted((limits or {}).items())),
            cases=cases,
            slow=slow,
        )
        return patch

    return register


def wrap(mp: pytest.MonkeyPatch, owner: object, name: str, make: Callable[[Fn], Fn]) -> None:
    """Replace `owner.name` by `make(original)`."""
    mp.setattr(owner, name, make(getattr(owner, name)))


def wrap_select(mp: pytest.MonkeyPatch, make: Callable[[Fn], Fn]) -> None:
    """Replace the history scan `select(messages, spec, *, now_ns, ...)` wherever it is called.

    `Whiteboard.retrieve` (registration retrieves) and `AIR.Retrieve` (which scans a snapshot,
    possibly off the loop: issue #19) both go through it, so a retrieve mutant patches it once
    for both paths.
    """
    from openair.server.core import retrieve, whiteboard

    mutated = make(whiteboard.select)
    mp.setattr(whiteboard, "select", mutated)
    mp.setattr(retrieve, "select", mutated)


# --- the router's outcomes -----------------------------------------------------------------------

Change = Callable[[Router, Delivery], Sequence[Delivery]]


def outcome_patch(mp: pytest.MonkeyPatch, change: Change) -> None:
    """Replace every delivery the router decides (requests, closed connections) by `change`'s."""

    def make(original: Fn) -> Fn:
        def wrapped(self: Router, *args: Any, **kwargs: Any) -> Outcome:
            outcome: Outcome = original(self, *args, **kwargs)
            if not outcome.deliveries:
                return outcome
            changed = tuple(new for d in outcome.deliveries for new in change(self, d))
            return replace(outcome, deliveries=changed)

        return wrapped

    for name in ("handle", "connection_closed"):
        wrap(mp, Router, name, make)


def with_message(d: Delivery, msg: Message) -> Delivery:
    """Return `d` carrying `msg`, without a frame written for the old message."""
    if any(f.name == "wire" for f in fields(d)):
        return replace(d, message=msg, wire=None)
    return replace(d, message=msg)


def wakeup_object(root: etree._Element, name: str) -> etree._Element | None:
    """Return the `<object name=…>` of a wakeup's objectdictionary, if any."""
    return next((obj for obj in root if obj.get("name") == name), None)


def child(el: etree._Element | None, name: str) -> etree._Element | None:
    """Return the first child element of `el` called `name` (any case), if any."""
    if el is None:
        return None
    return next((c for c in el if isinstance(c.tag, str) and local_name(c) == name), None)


def wakeup_patch(mp: pytest.MonkeyPatch, change: Callable[[etree._Element], None]) -> None:
    """Let `change` edit the objectdictionary of every wakeup (phase updates are left alone)."""

    def on_delivery(router: Router, d: Delivery) -> Sequence[Delivery]:
        msg = d.message
        if msg.type != WAKEUP or not msg.stored:  # a phase update has an empty stored
            return (d,)
        root = etree.fromstring(msg.content)
        change(root)
        return (with_message(d, replace(msg, content=etree.tostring(root, encoding="unicode"))),)

    outcome_patch(mp, on_delivery)


# --- doing the work of a request later -----------------------------------------------------------


def defer(mp: pytest.MonkeyPatch, method: str, now: Fn, *, requests: int) -> None:
    """Run `Router.<method>` only once the router has handled `requests` more requests.

    `now(self, *args)` is what the method returns at once instead. The deliveries of the late
    run join the outcome of the request after which it ran; its replies are dropped.
    """
    original = getattr(Router, method)

    def deferred(self: Router, *args: Any) -> Any:
        self.__dict__.setdefault("_mutant_deferred", []).append([requests, args])
        return now(self, *args)

    def make(handle: Fn) -> Fn:
        def wrapped(self: Router, *args: Any, **kwargs: Any) -> Outcome:
            queue: list[list[Any]] = self.__dict__.setdefault("_mutant_deferred", [])
            waiting = queue[:]
            outcome: Outcome = handle(self, *args, **kwargs)
            late: list[Delivery] = []
            for item in waiting:
                item[0] -= 1
                if item[0] == 0:
                    queue.remove(item)
                    done = original(self, *item[1])
                    late += done if isinstance(done, tuple) else done.deliveries
            return replace(outcome, deliveries=outcome.deliveries + tuple(late))

        return wrapped

    mp.setattr(Router, method, deferred)
    wrap(mp, Router, "handle", make)
