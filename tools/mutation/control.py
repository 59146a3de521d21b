"""The control run: which lines of the mutated modules each case executes on the clean server.

`python -m tools.mutation.control --out MAP.json MODULE...` runs in a pristine copy (the driver
sets the working folder and PYTHONPATH). Every case runs once, one at a time, under coverage.py
with one dynamic context per case (switched when the engine starts the case), so each line is
attributed to the cases that ran it; what runs before the first case (start-up, the engine's
probe) is STARTUP, what runs after the last (shutdown) TEARDOWN. The map also keeps each case's
verdict and duration: the judge runs only the cases that pass here, fastest first. Cases not
applicable at the default limits run on a second server with the limits they need
(`serving.CASE_LIMITS`), as in the judge.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import coverage  # type: ignore[import-not-found,unused-ignore]  # the `mutation` extra

from tools.mutation.selection import STARTUP, TEARDOWN

__all__ = ["load_map", "main"]


class _Switcher:
    """A reporter that moves coverage to the context of the case that starts."""

    def __init__(self, cov: coverage.Coverage) -> None:
        self._cov = cov

    def handle(self, event: object) -> None:
        from openair_conformance.model import CaseStarted

        if isinstance(event, CaseStarted):
            self._cov.switch_context(event.info.id)

    def close(self) -> None:
        """Nothing to close."""


def _measure(modules: Sequence[str], globs: Sequence[str], jobs: int) -> dict[str, Any]:
    root = Path.cwd()
    files = {str((root / m).resolve()): m for m in modules}
    cov = coverage.Coverage(data_file=None, include=list(files), config_file=False)
    cov.start()
    cov.switch_context(STARTUP)
    from openair_conformance.registry import all_cases, select_cases
    from tools.mutation.serving import by_limits, run_cases, serving

    known = {c.info.id: c for c in select_cases(all_cases(), globs=globs)}
    started = time.monotonic()
    results: list[Any] = []
    for limits, ids in by_limits(list(known)):
        cov.switch_context(STARTUP)
        with serving(limits) as target:
            cases = [known[i] for i in ids]
            summary = run_cases(
                target, cases, [_Switcher(cov)], jobs=jobs, timeout_scale=1.0, limits=limits
            )
            cov.switch_context(TEARDOWN)
        results += summary.results
    cov.stop()
    data = cov.get_data()
    lines: dict[str, dict[str, list[str]]] = {}
    for path, module in files.items():
        by_line = data.contexts_by_lineno(path)
        lines[module] = {str(n): sorted(c for c in ctx if c) for n, ctx in sorted(by_line.items())}
    return {
        "seconds": round(time.monotonic() - started, 1),
        "cases": {
            r.info.id: {"verdict": r.verdict.value, "seconds": round(r.duration, 3)}
            for r in results
        },
        "modules": lines,
    }


def load_map(path: Path) -> tuple[dict[str, dict[int, frozenset[str]]], dict[str, Any]]:
    """Read a map file: (module -> line -> contexts, case ID -> {verdict, seconds})."""
    raw = json.loads(path.read_text(encoding="utf-8"))
    cmap = {
        module: {int(n): frozenset(ctx) for n, ctx in lines.items()}
        for module, lines in raw["modules"].items()
    }
    return cmap, raw["cases"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the control and write the map (exit 0 when written)."""
    parser = argparse.ArgumentParser(prog="python -m tools.mutation.control")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--case", action="append", default=[], help="case ID glob (repeatable)")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("modules", nargs="+")
    args = parser.parse_args(argv)
    result = _measure(args.modules, args.case, args.jobs)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=0, sort_keys=True), encoding="utf-8")
    tmp.replace(args.out)
    print(f"control: {len(result['cases'])} cases in {result['seconds']} s -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
