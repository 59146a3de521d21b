"""Mutants of contexts and phases (spec 8.9, extension `contexts`), one deliberate fault each.

Seams: `openair.server.core.contexts` (only the server imports it) and the router's methods and the
names it imports. Each fault is the one-line slip of an implementer of OA-REG-13..18; the CTX
cases catch them (CTX-001 in wakeups.py, CTX-002..005 in contexts.py).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.content import Phase, Registration
from openair.protocol.message import Message
from openair.server.core import contexts, router_registrations
from openair.server.core.contexts import Contexts
from openair.server.core.router import Delivery, Router
from openair.server.core.whiteboard import Whiteboard

_CASES = ("CTX-*",)


@mutant(
    "ctx-ancestor-replaces",
    "posting an ancestor of the active context replaces it",
    "OA-REG-13",
    cases=_CASES,
)
def _ancestor_replaces(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def activate(self: Contexts, context: str) -> bool:
            segs = contexts._segments(context)
            root = self._roots.get(segs[0])
            if root is not None and root.active != segs and root.active[: len(segs)] == segs:
                root.active = segs  # the slip: an ancestor taken as a switch
                root.since = root.since[: len(segs)]
                return True
            return bool(original(self, context))

        return activate

    wrap(mp, Contexts, "activate", make)


@mutant("ctx-one-root", "one active context for all roots", "OA-REG-13", cases=_CASES)
def _one_root(mp: pytest.MonkeyPatch) -> None:
    original = contexts._segments
    mp.setattr(contexts, "_segments", lambda context: ("", *original(context)))


@mutant("ctx-case-sensitive", "context names compared case-sensitively", "OA-REG-13", cases=_CASES)
def _case_sensitive(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(contexts, "ascii_fold", lambda text: text)


@mutant(
    "ctx-first-listed",
    "the first listed context in force wins, not the most recent",
    "OA-REG-14",
    cases=_CASES,
)
def _first_listed(mp: pytest.MonkeyPatch) -> None:
    def first(self: Contexts, reg: Registration) -> tuple[str, int] | None:
        for phase in reg.phases:
            since = self.since(phase.context)
            if since is not None:
                return phase.context, since
        return None

    mp.setattr(Contexts, "_context_in_force", first)


@mutant(
    "ctx-shallow-tie",
    "of two contexts that came into force together the shallower wins",
    "OA-REG-14",
    cases=_CASES,
)
def _shallow_tie(mp: pytest.MonkeyPatch) -> None:
    def shallow(self: Contexts, reg: Registration) -> tuple[str, int] | None:
        best: tuple[int, int, str] | None = None
        for phase in reg.phases:
            since = self.since(phase.context)
            if since is None:
                continue
            key = (since, -len(phase.context.split(".")), phase.context)
            if best is None or key[:2] > best[:2]:
                best = key
        return None if best is None else (best[2], best[0])

    mp.setattr(Contexts, "_context_in_force", shallow)


@mutant(
    "ctx-cc-needs-phase",
    "cc does not wake a module out of context",
    "OA-REG-14",
    cases=_CASES,
)
def _cc_needs_phase(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def woken(self: Router, board: Whiteboard, stored: Message) -> dict[str, Any]:
            chosen: dict[str, Any] = original(self, board, stored)
            return {
                name: v
                for name, v in chosen.items()
                if v[1] or self._phase_in_force(name, self.registration(name)) is not None
            }

        return woken

    wrap(mp, Router, "_woken", make)


@mutant("ctx-no-phase-update", "no phase update when the phase changes", "OA-REG-15", cases=_CASES)
def _no_phase_update(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(Router, "_phase_update", lambda self, name, now_ns: ())


@mutant(
    "ctx-update-default-phase",
    "an out-of-context phase update carries a default PhaseSpec, not an empty dictionary",
    "OA-REG-15",
    cases=_CASES,
)
def _update_default_phase(mp: pytest.MonkeyPatch) -> None:
    original = router_registrations.build_wakeup

    def build(**kwargs: Any) -> Message:
        if kwargs.get("phase") is None:
            kwargs["phase"] = Phase()
        return original(**kwargs)

    mp.setattr(router_registrations, "build_wakeup", build)


@mutant("ctx-phasechange-ignored", "PhaseChange does not advance", "OA-REG-17", cases=_CASES)
def _phasechange_ignored(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(Contexts, "advance", lambda self, module, reg: False)


@mutant("ctx-phasechange-no-wrap", "PhaseChange stays at the last phase", "OA-REG-17", cases=_CASES)
def _phasechange_no_wrap(mp: pytest.MonkeyPatch) -> None:
    def advance(self: Contexts, module: str, reg: Registration | None) -> bool:
        found = self._context_in_force(reg) if reg is not None else None
        if reg is None or found is None:
            return False
        context, since = found
        phases = [p for p in reg.phases if p.context == context]
        index = next(i for i, p in enumerate(phases) if p is self.phase(module, reg))
        self._steps[module] = contexts._Step(
            registration=reg,
            context=contexts._segments(context),
            since=since,
            index=min(index + 1, len(phases) - 1),  # the slip: no wrap after the last
        )
        return True

    mp.setattr(Contexts, "advance", advance)


@mutant(
    "ctx-reentry-keeps-phase",
    "a context coming into force again keeps the phase it had reached",
    "OA-REG-17",
    cases=_CASES,
)
def _reentry_keeps_phase(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def context_in_force(self: Contexts, reg: Registration) -> tuple[str, int] | None:
            found = original(self, reg)
            return None if found is None else (found[0], 0)  # the activation is forgotten

        return context_in_force

    wrap(mp, Contexts, "_context_in_force", make)


@mutant(
    "ctx-change-after-wakeups",
    "a context post's change applies after its own wakeups are decided",
    "OA-REG-18",
    cases=_CASES,
)
def _change_after_wakeups(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def context_post(
            self: Router, board: Whiteboard, stored: Message, now_ns: int
        ) -> tuple[Delivery, ...]:
            early = self._decide(board, stored, now_ns)
            setattr(self, "_decide", lambda *args: early)  # noqa: B010 (a method shadowed)
            try:
                return tuple(original(self, board, stored, now_ns))
            finally:
                delattr(self, "_decide")

        return context_post

    wrap(mp, Router, "_context_post", make)
