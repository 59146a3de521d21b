"""Run the registered benchmarks and print one table: `python -m bench [NAME ...]`.

A benchmark is any module `bench/bench_<name>.py` with a `run() -> list[Result]` function.
NAME arguments keep only the modules whose <name> contains one of them. Exit status: 0 when
every selected benchmark ran, 1 when one raised (the others still run), 2 when no module was
selected.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
import traceback
from collections.abc import Sequence

import bench
from bench import Result

_HEADER = ("benchmark", "case", "value", "unit", "x baseline", "note")


def discover(filters: Sequence[str] = ()) -> list[str]:
    """Return the names of the benchmark modules, sorted, keeping those that match a filter."""
    names = sorted(
        info.name for info in pkgutil.iter_modules(bench.__path__) if info.name.startswith("bench_")
    )
    if filters:
        names = [n for n in names if any(f in n.removeprefix("bench_") for f in filters)]
    return names


def _row(result: Result) -> tuple[str, ...]:
    ratio = "" if result.ratio is None else f"{result.ratio:.2f}"
    return (result.bench, result.case, f"{result.value:.3f}", result.unit, ratio, result.note)


def format_table(results: Sequence[Result]) -> str:
    """Render results as an aligned plain-text table."""
    rows = [_HEADER, *(_row(r) for r in results)]
    widths = [max(len(row[i]) for row in rows) for i in range(len(_HEADER))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(line.rstrip() for line in lines)


def main(argv: Sequence[str]) -> int:
    """Run the selected benchmarks, print their table and return the exit status."""
    names = discover(argv)
    if not names:
        print("no benchmark module matches", " ".join(argv), file=sys.stderr)
        return 2
    results: list[Result] = []
    status = 0
    for name in names:
        print(f"running {name} ...", file=sys.stderr, flush=True)
        try:
            results.extend(importlib.import_module(f"bench.{name}").run())
        except Exception:
            traceback.print_exc()
            status = 1
    print(format_table(results))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
