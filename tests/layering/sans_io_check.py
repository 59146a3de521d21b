"""What makes a module not sans-I/O (issue #17), read from its source with `ast`.

A module of `openair/protocol` or `openair/server/core` may not import a module that waits
on or talks to the outside world (asyncio, socket, threading, selectors, ssl, subprocess,
sqlite3, …) nor `time`, and may not read the clock by any other road (`datetime.now()`,
`loop.time()`).
Lazy imports count (they run); imports under `if TYPE_CHECKING:` do not.
"""

from __future__ import annotations

import ast
from pathlib import Path

from layering_imports import imports_of

#: Modules whose import makes a module not sans-I/O; `time` is the clock.
FORBIDDEN_MODULES = frozenset(
    {
        "asyncio",
        "socket",
        "threading",
        "_thread",
        "selectors",
        "ssl",
        "subprocess",
        "multiprocessing",
        "sqlite3",  # a durable store is the adapter's (server/aio/stores.py)
        "concurrent",
        "time",
    }
)
#: Calls that read the clock without importing `time`: `datetime.now()`, `date.today()`, ….
_CLOCK_METHODS = frozenset({"now", "utcnow", "today"})
_CLOCK_OWNERS = frozenset({"datetime", "date"})


def _clock_reads(tree: ast.AST) -> list[tuple[int, str]]:
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        attr, owner = node.func.attr, node.func.value
        owner_name = owner.id if isinstance(owner, ast.Name) else getattr(owner, "attr", "")
        if attr in _CLOCK_METHODS and owner_name in _CLOCK_OWNERS:
            found.append((node.lineno, f"{owner_name}.{attr}()"))
        elif attr == "time" and (
            "loop" in owner_name.lower()
            or (isinstance(owner, ast.Call) and "loop" in ast.unparse(owner.func).lower())
        ):
            found.append((node.lineno, f"{ast.unparse(node.func)}()"))  # the event loop's clock
    return found


def io_problems(path: Path, root: Path) -> list[str]:
    """Every import of a forbidden module and every clock read in the module at `path`."""
    problems = [
        f"{path}:{i.line} imports {i.target}"
        for i in imports_of(path, root)
        if i.target.split(".")[0] in FORBIDDEN_MODULES
    ]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    problems += [f"{path}:{line} reads the clock: {what}" for line, what in _clock_reads(tree)]
    return sorted(set(problems))
