"""Contexts and phases (spec 8.9, extension `contexts`): which phase of a module is in force.

Sans-I/O. `Contexts` keeps one active context per root (OA-REG-13) and, for every prefix of an
active context, the activation that brought it into force (a sequence number, so that "most
recently came into force" is exact and deterministic). A module's phase in force is the phase
of its context that came into force last, deeper contexts first on a tie (OA-REG-14), advanced
within the context by `Psyclone.Module.Report.PhaseChange` (OA-REG-17) and back at the first
phase whenever its context comes into force again. Context names compare segment by segment
with ASCII case folded, as the type that carries them does (OA-REG-13).
"""

from __future__ import annotations

from dataclasses import dataclass

from openair.protocol.content import DEFAULT_CONTEXT, Phase, Registration
from openair.protocol.matching import ascii_fold

__all__ = ["CONTEXT_PREFIX", "PHASE_CHANGE", "Contexts", "context_of"]

CONTEXT_PREFIX = "Psyclone.Context:"  # spec 8.9: the type that activates a context
PHASE_CHANGE = "Psyclone.Module.Report.PhaseChange"  # OA-REG-17


def context_of(type_: str) -> str | None:
    """Return the context a `Psyclone.Context:<context>` type activates, or None.

    A name with an empty segment, or none at all, activates nothing (the post is still stored).
    """
    if not type_.startswith(CONTEXT_PREFIX):
        return None
    name = type_[len(CONTEXT_PREFIX) :]
    if not name or any(not seg for seg in name.split(".")):
        return None
    return name


def _segments(context: str) -> tuple[str, ...]:
    return tuple(ascii_fold(context).split("."))


@dataclass(slots=True)
class _Root:
    """The active context of one root and when each of its prefixes came into force."""

    active: tuple[str, ...]  # folded segments
    since: list[int]  # since[i]: the activation that brought active[: i + 1] into force


@dataclass(frozen=True, slots=True, kw_only=True)
class _Step:
    """How far a module advanced within its context (OA-REG-17)."""

    registration: Registration
    context: tuple[str, ...]
    since: int
    index: int


class Contexts:
    """The active contexts and the phase sequencing of every module (spec 8.9)."""

    def __init__(self) -> None:
        self._roots: dict[str, _Root] = {}
        self._activations = 0
        self._steps: dict[str, _Step] = {}
        self.activate(DEFAULT_CONTEXT)  # OA-SESS-31: Ready is active from start-up

    def active(self) -> tuple[str, ...]:
        """Return the active contexts (folded), one per root, sorted."""
        return tuple(sorted(".".join(r.active) for r in self._roots.values()))

    def activate(self, context: str) -> bool:
        """Make `context` the active context of its root; return whether it changed (OA-REG-13).

        Nothing changes when the root's active context equals `context` or descends from it.
        """
        segs = _segments(context)
        root = self._roots.get(segs[0])
        if root is not None and root.active[: len(segs)] == segs:
            return False  # OA-REG-13: equal, or the active context is a descendant
        self._activations += 1
        if root is None:
            self._roots[segs[0]] = _Root(active=segs, since=[self._activations] * len(segs))
            return True
        keep = 0
        while keep < min(len(segs), len(root.active)) and segs[keep] == root.active[keep]:
            keep += 1
        root.since = root.since[:keep] + [self._activations] * (len(segs) - keep)
        root.active = segs
        return True

    def since(self, context: str) -> int | None:
        """Return the activation that brought `context` into force, or None when it is not."""
        segs = _segments(context)
        root = self._roots.get(segs[0])
        if root is None or root.active[: len(segs)] != segs:
            return None
        return root.since[len(segs) - 1]

    def _context_in_force(self, reg: Registration) -> tuple[str, int] | None:
        """Return the module's context that came into force last, and since when (OA-REG-14)."""
        best: tuple[int, int, str] | None = None
        for phase in reg.phases:
            since = self.since(phase.context)
            if since is None:
                continue
            key = (since, len(_segments(phase.context)), phase.context)
            if best is None or key[:2] > best[:2]:
                best = key  # the latest activation; the deeper context on a tie
        return None if best is None else (best[2], best[0])

    def phase(self, module: str, reg: Registration | None) -> Phase | None:
        """Return the phase in force of `module` under `reg` (OA-REG-14, OA-REG-17)."""
        if reg is None:
            return None
        found = self._context_in_force(reg)
        if found is None:
            return None
        context, since = found
        phases = [p for p in reg.phases if p.context == context]
        step = self._steps.get(module)
        index = 0
        if (
            step is not None
            and step.registration is reg
            and step.context == _segments(context)
            and step.since == since
        ):
            index = step.index  # OA-REG-17: back at the first phase when the context re-enters
        return phases[index % len(phases)]

    def advance(self, module: str, reg: Registration | None) -> bool:
        """Move `module` to the next phase of its context, after the last the first (OA-REG-17).

        Return whether its phase in force changed (a context with one phase: it does not).
        """
        if reg is None:
            return False
        found = self._context_in_force(reg)
        if found is None:
            return False
        context, since = found
        count = sum(1 for p in reg.phases if p.context == context)
        current = self.phase(module, reg)
        index = next(
            i for i, p in enumerate(p for p in reg.phases if p.context == context) if p is current
        )
        self._steps[module] = _Step(
            registration=reg, context=_segments(context), since=since, index=(index + 1) % count
        )
        return count > 1

    def forget(self, module: str) -> None:
        """Drop a module's sequencing (a new registration starts at the first phase)."""
        self._steps.pop(module, None)
