"""Placeholders and paths in scenario steps: `{T}`, `{go.id}`, `trigger.type`, `messages[0].id`.

`Values` holds what earlier steps saved (`as="NAME"`) and expands placeholders; `lookup` follows
a dotted path with `[n]` indexes into a JSON value; `evaluate` applies one `<expect>` test.
"""

from __future__ import annotations

import math
import re
from typing import Any

from openair_conformance.clientmode.scenario import Expect

__all__ = ["MISSING", "Values", "evaluate", "lookup", "render"]


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


#: What `lookup` returns for a path that leads nowhere.
MISSING: Any = _Missing()
_PLACEHOLDER = re.compile(r"\{([A-Za-z][A-Za-z0-9_]*)(?:\.([^{}]+))?\}")
_PART = re.compile(r"([^.\[\]]+)|\[([0-9]+)\]")


class Values:
    """The scenario's named values: the fixed ones (T, module, kit) and what steps saved."""

    def __init__(self, **fixed: str) -> None:
        self._values: dict[str, Any] = dict(fixed)

    def save(self, name: str, value: Any) -> None:
        self._values[name] = value

    def get(self, name: str) -> Any:
        return self._values.get(name, MISSING)

    def expand(self, text: str) -> str:
        """Replace every placeholder; a name no step saved is a scenario bug (KeyError)."""

        def one(match: re.Match[str]) -> str:
            name, path = match.group(1), match.group(2)
            if name not in self._values:
                raise KeyError(f"placeholder {match.group(0)}: no value {name!r} was saved")
            value = self._values[name]
            if path:
                value = lookup(value, path)
                if value is MISSING:
                    raise KeyError(f"placeholder {match.group(0)}: no {path!r} in {name!r}")
            return value if isinstance(value, str) else render(value)

        return _PLACEHOLDER.sub(one, text)


def lookup(value: Any, path: str) -> Any:
    """Follow `a.b[0].c` into nested dicts and lists; MISSING when it leads nowhere."""
    for match in _PART.finditer(path):
        key, index = match.group(1), match.group(2)
        if key is not None:
            if not isinstance(value, dict) or key not in value:
                return MISSING
            value = value[key]
        else:
            if not isinstance(value, list) or int(index) >= len(value):
                return MISSING
            value = value[int(index)]
    return value


def render(value: Any) -> str:
    """A JSON value as scenario text: true, false, null, numbers, strings as they are."""
    if value is MISSING:
        return "(absent)"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and value.is_integer():
        return f"{value:.1f}"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return value
    return repr(value)


def _number(text: str) -> float | None:
    try:
        number = float(text)
    except ValueError:
        return None
    return number if math.isfinite(number) else None


def _equal(actual: Any, expected: str) -> bool:
    if isinstance(actual, (int, float)) and not isinstance(actual, bool):
        wanted = _number(expected)
        return wanted is not None and math.isclose(float(actual), wanted, abs_tol=1e-9)
    return actual is not MISSING and render(actual) == expected


def evaluate(expect: Expect, actual: Any, expected: str) -> bool:
    """Apply one test to the looked-up value; `expected` is the expanded value."""
    if expect.test == "equals":
        return _equal(actual, expected)
    if expect.test == "not-equals":
        return actual is not MISSING and not _equal(actual, expected)
    if expect.test == "count":
        return isinstance(actual, list) and len(actual) == int(expected)
    if expect.test == "min":
        bound = _number(expected)
        return (
            isinstance(actual, (int, float))
            and not isinstance(actual, bool)
            and bound is not None
            and actual >= bound
        )
    if expect.test == "present":
        present = actual is not MISSING and actual is not None
        return present == (expected in ("true", "1"))
    if expect.test == "one-of":
        return any(_equal(actual, option) for option in expected.split())
    raise ValueError(f"unknown test {expect.test!r}")
