"""The routing model FUZZ-001 judges the server by, written from the spec alone.

It holds what one fuzzing example did: which modules are bound, their registrations, and the
messages stored on each whiteboard. From that it answers two questions: who must be woken by a
stored message, and with which `lasttrigger` (spec 8.4–8.6); and what a retrieve returns (9.2,
9.3). Nothing here reads the reference server's code, and the matcher is written again from
section 5 (a monkeypatched server matcher must not change the model). No I/O.
"""

from __future__ import annotations

import string
from dataclasses import dataclass, field

__all__ = [
    "LOST_SENDER",
    "RoutingModel",
    "Stored",
    "Trigger",
    "board_matches",
    "cc_names",
    "glob_matches",
]

#: The sender of `Psyclone.Module.Lost.<name>` notices (OA-SESS-15).
LOST_SENDER = "Psyclone"
_ASCII_LOWER = str.maketrans(string.ascii_uppercase, string.ascii_lowercase)
_CC_BLANKS = " \t\r\n"


def _fold(text: str) -> str:
    return text.translate(_ASCII_LOWER)  # OA-MATCH-1: only A-Z fold


def glob_matches(pattern: str, type_: str) -> bool:
    """Return whether `pattern` matches `type_` (OA-MATCH-1..6)."""
    p, t = _fold(pattern), _fold(type_)
    if _whole(p.split("*"), t):  # OA-MATCH-2, OA-MATCH-3, OA-MATCH-5, OA-MATCH-6
        return True
    return p.endswith(".*") and t == p[:-2]  # OA-MATCH-4: the subtree root, literally


def _whole(parts: list[str], t: str) -> bool:
    """Return whether `t` is parts[0] + any + parts[1] + … + any + parts[-1], all of it."""
    if len(parts) == 1:
        return t == parts[0]
    first, last = parts[0], parts[-1]
    if len(t) < len(first) + len(last) or not t.startswith(first) or not t.endswith(last):
        return False
    at, end = len(first), len(t) - len(last)
    for middle in parts[1:-1]:  # leftmost placement never loses a match (linear, no regex)
        found = t.find(middle, at, end)
        if found < 0:
            return False
        at = found + len(middle)
    return True


def board_matches(trigger_from: str | None, board: str) -> bool:
    """Return whether a trigger's `from` names `board` (OA-TRIG-2)."""
    if trigger_from is None or trigger_from in ("", "any", "*"):
        return True
    return _fold(trigger_from) == _fold(board)


def cc_names(cc: str) -> frozenset[str]:
    """Return the module names of a `cc` slot (OA-CC-1: `;`, blanks around names, exact)."""
    return frozenset(n.strip(_CC_BLANKS) for n in cc.split(";") if n.strip(_CC_BLANKS))


@dataclass(frozen=True, slots=True, kw_only=True)
class Trigger:
    """One trigger of a registration: a pattern and its `from` (None: the attribute is absent)."""

    pattern: str
    board: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Stored:
    """A message a whiteboard stored, as far as routing and retrieving need it."""

    id: str
    type: str
    sender: str
    board: str


@dataclass(slots=True)
class _Module:
    triggers: tuple[Trigger, ...] = ()
    self_ok: bool = False


@dataclass(slots=True)
class RoutingModel:
    """Bound modules, their registrations and the stored messages of one example."""

    modules: dict[str, _Module] = field(default_factory=dict)
    boards: dict[str, list[Stored]] = field(default_factory=dict)

    @property
    def bound(self) -> tuple[str, ...]:
        """The names of the bound modules, sorted."""
        return tuple(sorted(self.modules))

    def bind(self, name: str) -> None:
        """A module binds: no registration yet (only its triggers decide, OA-TRIG-1)."""
        self.modules[name] = _Module()

    def unbind(self, name: str) -> None:
        """A module's primary connection closed: it and its registration are gone (OA-SESS-15)."""
        self.modules.pop(name, None)

    def subscribe(self, name: str, triggers: tuple[Trigger, ...], *, self_ok: bool) -> None:
        """Replace the module's whole registration (OA-REG-1, OA-REG-6)."""
        self.modules[name] = _Module(triggers=triggers, self_ok=self_ok)

    def registration(self, name: str) -> tuple[tuple[Trigger, ...], bool] | None:
        """Return a bound module's triggers and self-triggering flag (None if not bound)."""
        module = self.modules.get(name)
        return None if module is None else (module.triggers, module.self_ok)

    def post(self, stored: Stored, cc: str) -> dict[str, str]:
        """Store a message and return the modules it wakes, each with its `lasttrigger`."""
        self.boards.setdefault(stored.board, []).append(stored)
        named = cc_names(cc)
        woken: dict[str, str] = {}
        for name, module in sorted(self.modules.items()):
            fired = self._fired(name, module, stored)
            if fired is not None:
                woken[name] = fired  # OA-WAKE-6: all `after` are 0, the first match is reported
            elif name in named:
                woken[name] = ""  # OA-CC-2, OA-CC-4 (the poster too); OA-WAKE-4: empty
        return woken  # OA-WAKE-5: one entry per module; OA-CC-3: unbound names skipped

    @staticmethod
    def _fired(name: str, module: _Module, stored: Stored) -> str | None:
        if stored.sender == name and not module.self_ok:
            return None  # OA-TRIG-4: exact comparison of `from`
        for trigger in module.triggers:
            if board_matches(trigger.board, stored.board) and glob_matches(
                trigger.pattern, stored.type
            ):
                return trigger.pattern  # OA-TRIG-1
        return None

    def retrieve(
        self, board: str, pattern: str, *, sender: str | None = None, latest: int | None = None
    ) -> list[str]:
        """Return the ids a retrieve selects, newest first (OA-RET-3, OA-RET-4, OA-RET-6)."""
        hits = [
            s.id
            for s in reversed(self.boards.get(board, []))
            if glob_matches(pattern, s.type) and (sender is None or s.sender == sender)
        ]
        limit = 1 if latest is None else latest  # OA-RET-4: default 1, 0 = no limit
        return hits if limit == 0 else hits[:limit]
