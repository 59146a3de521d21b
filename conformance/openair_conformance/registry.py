"""The case table: the `@case(...)` decorator, lookup and selection.

Case modules live in `openair_conformance.cases` (one per spec section); `all_cases()` imports
them all, so a new module there is picked up without editing any list. IDs follow
`GROUP-NNN` (`model.CASE_ID_PATTERN`), are stable and are never reused: a duplicate ID fails at
import, and the IDs of removed cases go into `RETIRED_IDS` so they cannot come back with a new
meaning. That every cited requirement exists in the catalogue is checked by a test
(tests/conformance/test_engine_registry.py), not at import.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Awaitable, Callable, Iterable, Sequence
from dataclasses import dataclass
from fnmatch import fnmatchcase
from functools import cache
from typing import TYPE_CHECKING, TypeAlias

from openair.catalogue import Requirement, load_catalogue
from openair_conformance.model import CaseInfo, Level

if TYPE_CHECKING:
    from openair_conformance.harness.context import CaseContext

__all__ = [
    "RETIRED_IDS",
    "CaseFn",
    "RegisteredCase",
    "RegistryError",
    "all_cases",
    "case",
    "get_case",
    "load_cases",
    "requirement_sentences",
    "select_cases",
]

CaseFn: TypeAlias = "Callable[[CaseContext], Awaitable[None]]"

#: IDs of cases that were removed; they are never given to another case.
RETIRED_IDS: frozenset[str] = frozenset()

#: Modules imported by `load_cases` besides every submodule of `openair_conformance.cases`.
_OPTIONAL_CASE_MODULES = ("openair_conformance.fuzz",)


class RegistryError(Exception):
    """A case definition breaks the ID rules (duplicate, retired or malformed ID)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class RegisteredCase:
    """A case: its description and the coroutine function that runs it."""

    info: CaseInfo
    fn: CaseFn

    @property
    def doc(self) -> str:
        """The case function's docstring (what it does, step by step), dedented."""
        return inspect.getdoc(self.fn) or ""


_CASES: dict[str, RegisteredCase] = {}


def case(
    *,
    id: str,
    title: str,
    section: str,
    requirements: Sequence[str],
    level: Level = Level.MUST,
    needs: Iterable[str] = (),
    serial: bool = False,
    allowed: Sequence[str] = (),
    residue: bool = False,
) -> Callable[[CaseFn], CaseFn]:
    """Register the decorated coroutine function as a conformance case.

    Raises RegistryError for a retired or duplicate ID and ValueError (from CaseInfo) for a
    malformed one.
    """
    info = CaseInfo(
        id=id,
        title=title,
        section=section,
        requirements=tuple(requirements),
        level=level,
        needs=frozenset(needs),
        serial=serial,
        allowed=tuple(allowed),
        residue=residue,
    )

    def register(fn: CaseFn) -> CaseFn:
        if not inspect.iscoroutinefunction(fn):
            raise RegistryError(f"{id}: a case must be an async function")
        if id in RETIRED_IDS:
            raise RegistryError(f"{id} is retired and cannot be reused")
        known = _CASES.get(id)
        if known is not None and not _same_function(known.fn, fn):
            raise RegistryError(f"duplicate case id {id}: {_where(known.fn)} and {_where(fn)}")
        _CASES[id] = RegisteredCase(info=info, fn=fn)
        return fn

    return register


def _same_function(a: CaseFn, b: CaseFn) -> bool:
    """Return whether two functions are the same definition (a module reload re-registers)."""
    return _where(a) == _where(b)


def _where(fn: CaseFn) -> str:
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', '?')}"


def load_cases() -> None:
    """Import every case module (each submodule of `openair_conformance.cases`, and fuzz)."""
    importlib.import_module("openair_conformance.cases")
    for name in _OPTIONAL_CASE_MODULES:
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as exc:
            # Not installed, or without its optional dependency (hypothesis: the `fuzz` extra);
            # any other missing module inside it is a real error.
            if exc.name not in (name, "hypothesis"):
                raise


def all_cases() -> list[RegisteredCase]:
    """Return every registered case, sorted by ID (imports the case modules first)."""
    load_cases()
    return [_CASES[key] for key in sorted(_CASES)]


def get_case(case_id: str) -> RegisteredCase:
    """Return the case with this ID (KeyError if there is none)."""
    load_cases()
    return _CASES[case_id]


def select_cases(
    cases: Iterable[RegisteredCase],
    *,
    globs: Sequence[str] = (),
    sections: Sequence[str] = (),
) -> list[RegisteredCase]:
    """Keep the cases whose ID matches any glob and whose section is within any section given.

    Globs use fnmatch syntax on the ID, case-sensitively (`MATCH-*`, `SESS-00?`). A section
    `6` selects 6, 6.1, 6.1.2 …; `6.1` selects 6.1 and below. Empty filters select everything.
    """
    selected = []
    for item in cases:
        if globs and not any(fnmatchcase(item.info.id, glob) for glob in globs):
            continue
        if sections and not any(_in_section(item.info.section, s) for s in sections):
            continue
        selected.append(item)
    return selected


def _in_section(section: str, wanted: str) -> bool:
    wanted = wanted.strip().rstrip(".")
    return section == wanted or section.startswith(wanted + ".")


@cache
def _catalogue() -> dict[str, Requirement]:
    return load_catalogue()


def requirement_sentences(info: CaseInfo) -> list[tuple[str, str, str]]:
    """Return (ID, level, sentence) for each requirement the case cites, from the catalogue.

    For reporters: the sentence of an ID missing from the catalogue is "(not in the catalogue)"
    and its level "?" (tests/conformance/test_engine_registry.py keeps that from shipping).
    """
    catalogue = _catalogue()
    rows = []
    for req_id in info.requirements:
        req = catalogue.get(req_id)
        if req is None:
            rows.append((req_id, "?", "(not in the catalogue)"))
        else:
            rows.append((req.id, req.level, req.text))
    return rows
