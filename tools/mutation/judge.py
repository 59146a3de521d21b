"""The judge: cosmic-ray's test command. Exit 0 = the mutant survived, non-zero = killed.

`python -m tools.mutation.judge --map MAP.json --pristine DIR` runs in a worker's copy, where
cosmic-ray has just mutated one module. It finds the mutated lines by comparing the copy's
modules with the pristine copy, picks the cases that executed those lines in the control run
(`selection.select_cases_for`; only cases that passed there), starts the mutated server
in-process and runs them, fastest first, four at a time; the first case that ends `fail`,
`pass-nonstrict` (a SHOULD failed) or `error`, a server that dies, or one that does not
start kills the mutant, and so does a case that ends `timing` twice (the second time alone, on
a new server). A mutant on a line no case executes survives without a run ("not-executed").
With no mutation found (cosmic-ray's baseline) every passing case runs: the clean server must
survive.

The last line of standard output is a JSON record (verdict, kind, lines, cases, killer,
seconds) that cosmic-ray stores as the result's output; the report reads it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tools.mutation.control import load_map
from tools.mutation.selection import Selection, changed_lines, select_cases_for

__all__ = ["KILLED", "SURVIVED", "find_mutation", "main"]

SURVIVED = 0
KILLED = 1
#: Verdicts that catch a mutant at once: a MUST failed, a SHOULD failed (`pass-nonstrict`: the
#: suite reports the deviation; only cases that pass on the clean server are run), or the
#: harness broke on the server's answer. A missed deadline (`timing`) catches it only when the
#: case, run again alone on a new server, misses it again: on a loaded machine a clean server
#: misses one now and then.
_CATCHING = frozenset({"fail", "pass-nonstrict", "error"})
_TIMING = "timing"
_JOBS = 4


class _Caught(Exception):
    """Raised from the reporter to stop the run at the first catching case."""

    def __init__(self, case_id: str, verdict: str) -> None:
        super().__init__(case_id)
        self.case_id, self.verdict = case_id, verdict


class _FirstCatch:
    """A reporter that stops the engine at the first case that catches the mutant; it notes
    the cases that missed a deadline (and stops at them too when `timing_catches`)."""

    def __init__(self, *, timing_catches: bool) -> None:
        self.timing_catches = timing_catches
        self.late: list[str] = []

    def handle(self, event: object) -> None:
        from openair_conformance.model import CaseFinished

        if not isinstance(event, CaseFinished):
            return
        verdict, case_id = event.result.verdict.value, event.result.info.id
        if verdict in _CATCHING or (verdict == _TIMING and self.timing_catches):
            raise _Caught(case_id, verdict)
        if verdict == _TIMING:
            self.late.append(case_id)

    def close(self) -> None:
        """Nothing to close."""


def find_mutation(root: Path, pristine: Path, modules: Sequence[str]) -> tuple[str, list[int]]:
    """Return (module, changed original lines) of the first module of `root` that differs
    from `pristine`, or ("", []) when none does."""
    for module in modules:
        original = (pristine / module).read_text(encoding="utf-8")
        now = (root / module).read_text(encoding="utf-8")
        if now != original:
            return module, changed_lines(original, now)
    return "", []


def _selection(root: Path, pristine: Path, map_path: Path) -> tuple[str, Selection]:
    cmap, cases = load_map(map_path)
    passing = sorted(
        (case_id for case_id, info in cases.items() if info["verdict"] == "pass"),
        key=lambda case_id: (cases[case_id]["seconds"], case_id),
    )
    module, lines = find_mutation(root, pristine, sorted(cmap))
    if not module:
        return "", Selection(kind="baseline", cases=tuple(passing), lines=())
    source = (pristine / module).read_text(encoding="utf-8")
    return module, select_cases_for(cmap, module, source, lines, passing)


def _pass(case_ids: Sequence[str], timeout_scale: float, *, jobs: int, confirm: bool) -> Any:
    """Run the cases on new (mutated) servers, one per set of limits the cases need; return
    whether the target died and the cases that were late."""
    from openair_conformance.registry import all_cases
    from tools.mutation.serving import by_limits, run_cases, serving

    known = {c.info.id: c for c in all_cases()}
    catch = _FirstCatch(timing_catches=confirm)
    for limits, ids in by_limits([i for i in case_ids if i in known]):
        with serving(limits) as target:
            cases = [known[i] for i in ids]
            summary = run_cases(
                target, cases, [catch], jobs=jobs, timeout_scale=timeout_scale, limits=limits
            )
        if summary.target_deaths:
            return summary.target_deaths[0], catch.late
    return None, catch.late


def _run(case_ids: Sequence[str], timeout_scale: float) -> dict[str, Any]:
    """Start the (mutated) server, run the cases; return the verdict record."""
    late: list[str] = []
    try:
        death, late = _pass(case_ids, timeout_scale, jobs=_JOBS, confirm=False)
        if death is None and late:  # confirm alone, one at a time
            death, _ = _pass(late, timeout_scale, jobs=1, confirm=True)
    except _Caught as caught:
        again = " again" if late and caught.verdict == _TIMING else ""
        return {"verdict": "killed", "killer": f"{caught.case_id} ({caught.verdict}{again})"}
    except Exception as exc:  # the mutated server did not start or broke the harness
        return {"verdict": "killed", "killer": f"crash: {type(exc).__name__}: {exc}"[:300]}
    if death is not None:
        return {"verdict": "killed", "killer": f"{death.case} (target died)"}
    return {"verdict": "survived", "killer": "", "late_once": late}


def main(argv: Sequence[str] | None = None) -> int:
    """Judge the mutant in the current folder; print the record; return 0 (survived) or 1."""
    started = time.monotonic()
    parser = argparse.ArgumentParser(prog="python -m tools.mutation.judge")
    parser.add_argument("--map", type=Path, required=True, help="the control's coverage map")
    parser.add_argument("--pristine", type=Path, required=True, help="the unmutated copy")
    parser.add_argument("--timeout-scale", type=float, default=1.0)
    args = parser.parse_args(argv)
    module, selection = _selection(Path.cwd(), args.pristine, args.map)
    record: dict[str, Any] = {
        "module": module,
        "kind": selection.kind,
        "lines": list(selection.lines),
        "cases": len(selection.cases),
    }
    if selection.kind == "not-executed":
        record |= {"verdict": "survived", "killer": ""}
    else:
        record |= _run(selection.cases, args.timeout_scale)
    record["seconds"] = round(time.monotonic() - started, 2)
    print(json.dumps(record, sort_keys=True), flush=True)
    # A broken server may leave threads behind: leave without waiting for them.
    os._exit(SURVIVED if record["verdict"] == "survived" else KILLED)


if __name__ == "__main__":
    sys.exit(main())
