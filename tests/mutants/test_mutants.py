"""The suite proves itself: every mutant server (mutants.py) is caught by some conformance case.

For each mutant the reference server is started with the fault active (in a background thread
with its own event loop, as in tests/conformance/test_suite_reference.py) and the cases that
could plausibly catch it run against it in-process: those citing one of its requirements, those
in the sections of those requirements, and any it names (`OPT_IN` cases run only when named). A
mutant is caught when one of them ends `fail`, `error`, `timing` or `pass-nonstrict` (a SHOULD
case that saw its requirement broken). The control runs every selected case once against the
clean server: a case that does not pass there is not counted as a catcher. About 200 mutants
and the control take about three minutes.

`test-artifacts/mutants.md` gets the mutant x catching-cases table and the cases that no mutant
ever made fail ("possibly vacuous"). Mutants no case catches are suite gaps: they are listed in
`KNOWN_GAPS` (xfail, strict) with what the suite lacks.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import Coroutine, Iterator, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import pytest
from mutants import CATALOGUE, Fault, Mutant, spec_match
from server_thread import ServerThread
from suite_runs import run_suite

from openair.catalogue import DEFAULT_CATALOGUE, load_catalogue
from openair_conformance.engine import RunOptions, run
from openair_conformance.model import CaseResult, Level, Verdict
from openair_conformance.registry import RegisteredCase, all_cases, select_cases

app = pytest.importorskip("openair.server.aio.app")
config = pytest.importorskip("openair.server.core.config")

#: Small deadlines: a mutant that loses a reply or a wakeup costs 4 deadlines per case.
TIMEOUT_SCALE = 0.5
JOBS = 4
#: A SHOULD case that sees its requirement broken reports pass-nonstrict: the fault is caught
#: (as the campaign's judge counts it, tools/mutation/judge.py).
CATCHING = frozenset({Verdict.FAIL, Verdict.ERROR, Verdict.TIMING, Verdict.PASS_NONSTRICT})
#: Cases that run only for a mutant that names them (`Mutant.cases`): slow ones (10 000 posts,
#: a 16 MiB frame, a retrieve over max-frame-xml, a queue of 10 000 deliveries) would stall the
#: server for the other cases running beside them, and FUZZ-001 is random and shrinks for up to
#: 15 s x timeout scale once it diverges (when named it runs a fixed seed).
OPT_IN = ("WB-004", "FRAME-010", "RET-012", "DELIV-014", "FUZZ-*")
FUZZ_EXAMPLES = 10
FUZZ_SEED = "20261122"
REPORT = Path(__file__).resolve().parents[2] / "test-artifacts" / "mutants.md"
VECTORS = DEFAULT_CATALOGUE.parent / "vectors" / "wildcards" / "wildcards.json"

#: Mutants no case catches (a gap in the suite): mutant id -> what the suite lacks.
KNOWN_GAPS: dict[str, str] = {}

Limits = tuple[tuple[str, int], ...]


@contextlib.contextmanager
def _serving(limits: Limits) -> Iterator[tuple[str, int]]:
    options = app.ServerOptions(
        host="127.0.0.1", port=0, limits=config.ServerLimits(**dict(limits)), grace_s=0.2
    )
    thread = ServerThread(lambda: _reference_path(app.start_server(options)))
    try:
        yield ("127.0.0.1", thread.port)
    finally:
        thread.stop()


async def _reference_path(starting: Coroutine[Any, Any, Any]) -> Any:
    """The mutants change the reference code: serve without a data path in front (issue #20),
    which would take the frames before the mutated reader and decoder see them."""
    server = await starting
    server.datapath = None
    return server


#: Cases that fill a server-wide budget (max-held-bytes) or need it empty: each runs on a fresh
#: server of its own, as tools/mutation/serving.py and test_suite_reference.py give them.
OWN_SERVER = frozenset({"LIM-014", "LIM-016", "LIM-041"})


def _run_cases(
    limits: Limits, cases: Sequence[RegisteredCase], *, rerun_late: bool = False
) -> dict[str, CaseResult]:
    """Run `cases` against a fresh server (the mutant's, when one is active); those of
    `OWN_SERVER` each against one of their own.

    With `rerun_late` (the clean server only) a late case is run again alone (suite_runs).
    """
    rest = [c for c in cases if c.info.id not in OWN_SERVER]
    groups = ([rest] if rest else []) + [[c] for c in cases if c.info.id in OWN_SERVER]
    results: dict[str, CaseResult] = {}
    for group in groups:
        results.update(_run_on_one_server(limits, group, rerun_late=rerun_late))
    return results


def _run_on_one_server(
    limits: Limits, cases: Sequence[RegisteredCase], *, rerun_late: bool
) -> dict[str, CaseResult]:
    with _serving(limits) as target:
        options = RunOptions(
            target=target,
            jobs=JOBS,
            timeout_scale=TIMEOUT_SCALE,
            fuzz_examples=FUZZ_EXAMPLES,
            replay=FUZZ_SEED,
        )
        if rerun_late:
            results = run_suite(options, cases)[1]
        else:
            results = list(asyncio.run(run(options, cases=cases)).results)
    return {r.info.id: r for r in results}


@cache
def _cases() -> dict[str, RegisteredCase]:
    return {c.info.id: c for c in all_cases()}


@cache
def selection(mutant_id: str) -> tuple[str, ...]:
    """Return the IDs of the cases that could plausibly catch the mutant."""
    m = CATALOGUE[mutant_id]
    catalogue = load_catalogue()
    sections = sorted({catalogue[r].section for r in m.requirements})
    cases = [c for c in _cases().values() if not select_cases([c], globs=OPT_IN)]
    chosen = {c.info.id for c in cases if set(c.info.requirements) & set(m.requirements)}
    chosen |= {c.info.id for c in select_cases(cases, sections=sections)}
    if m.cases:
        chosen |= {c.info.id for c in select_cases(_cases().values(), globs=m.cases)}
    return tuple(sorted(chosen))


@cache
def control() -> dict[Limits, dict[str, CaseResult]]:
    """Run every selected case once against the clean server, per set of limits.

    A case that is only late (TIMING: inside the grace, never FAIL) is run once more alone:
    four jobs on a loaded two-core machine can push a wakeup past the halved deadline, and the
    clean server is not what is being judged here. A case late again alone stays TIMING.
    """
    wanted: dict[Limits, set[str]] = {}
    for m in CATALOGUE.values():
        wanted.setdefault(m.limits, set()).update(selection(m.id))
    return {
        limits: _run_cases(limits, [_cases()[i] for i in sorted(ids)], rerun_late=True)
        for limits, ids in sorted(wanted.items())
    }


@dataclass(frozen=True, slots=True, kw_only=True)
class Outcome:
    """What the suite did to one mutant."""

    mutant: Mutant
    ran: tuple[str, ...]  # the selected cases that pass against the clean server
    results: dict[str, CaseResult]
    duration: float

    @property
    def catchers(self) -> list[CaseResult]:
        return [r for r in self.results.values() if r.verdict in CATCHING]


_OUTCOMES: dict[str, Outcome] = {}


def outcome(mutant_id: str) -> Outcome:
    """Run the mutant's selection against the mutant server (once per session)."""
    if mutant_id not in _OUTCOMES:
        m = CATALOGUE[mutant_id]
        clean = control()[m.limits]
        ran = tuple(i for i in selection(m.id) if clean[i].verdict is Verdict.PASS)
        started = time.monotonic()
        with m.active():
            results = _run_cases(m.limits, [_cases()[i] for i in ran]) if ran else {}
        _OUTCOMES[mutant_id] = Outcome(
            mutant=m, ran=ran, results=results, duration=time.monotonic() - started
        )
    return _OUTCOMES[mutant_id]


def _explain(results: Sequence[CaseResult]) -> str:
    return "\n".join(f"{r.info.id} {r.verdict.value}: {r.message[:300]}" for r in results)


def _params() -> list[Any]:
    params = []
    for m in CATALOGUE.values():
        marks: list[Any] = [pytest.mark.slow] if m.slow else []
        if m.id in KNOWN_GAPS:
            marks.append(pytest.mark.xfail(strict=True, reason=KNOWN_GAPS[m.id]))
        params.append(pytest.param(m.id, marks=marks, id=m.id))
    return params


def test_control_selected_cases_pass_on_the_clean_server() -> None:
    """Every selected case passes on the clean server (not applicable only with a reason)."""
    bad = [
        r
        for results in control().values()
        for r in results.values()
        if r.verdict is not Verdict.PASS
        and not (r.verdict is Verdict.NOT_APPLICABLE and r.message.strip())
    ]
    assert not bad, _explain(bad)


@pytest.mark.parametrize("mutant_id", _params())
def test_mutant_is_caught(mutant_id: str) -> None:
    """Some selected case fails, errors or misses a deadline against the mutant."""
    result = outcome(mutant_id)
    assert result.ran, f"{mutant_id}: no selected case passes against the clean server"
    assert result.catchers, (
        f"{mutant_id} ({result.mutant.description}) survived {len(result.ran)} cases:\n"
        + _explain(list(result.results.values()))
    )


def test_fault_free_matcher_agrees_with_the_vectors() -> None:
    """The mutants' matcher is OA-MATCH-1..6 until a fault is switched on; each fault shows."""
    rows = json.loads(VECTORS.read_text(encoding="utf-8"))["rows"]
    rows = [r for r in rows if r["expected"] in ("match", "nomatch")]
    wrong = [r for r in rows if spec_match(r["pattern"], r["type"]) != (r["expected"] == "match")]
    assert rows and not wrong
    faults = [
        Fault(fold=False),
        Fault(dots=False),
        Fault(root="none"),
        Fault(root="glob"),
        Fault(literal_prefix=True),
        Fault(overlap=True),
    ]
    for fault in faults:
        assert any(
            spec_match(r["pattern"], r["type"], fault) != (r["expected"] == "match") for r in rows
        ), fault


def test_mutant_catalogue_is_well_formed() -> None:
    """Every mutant cites catalogue requirements and selects cases; at most 5 known gaps."""
    catalogue = load_catalogue()
    assert len(CATALOGUE) >= 30
    for m in CATALOGUE.values():
        assert m.requirements and all(r in catalogue for r in m.requirements), m.id
        assert selection(m.id), m.id
    assert set(KNOWN_GAPS) <= set(CATALOGUE)
    assert len(KNOWN_GAPS) <= 5


def _table(outcomes: Sequence[Outcome]) -> list[str]:
    lines = [
        "| mutant | breaks | fault | cases run | caught by | s |",
        "|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        caught = ", ".join(f"{r.info.id} ({r.verdict.value})" for r in o.catchers)
        lines.append(
            f"| {o.mutant.id} | {' '.join(o.mutant.requirements)} | {o.mutant.description} "
            f"| {len(o.ran)} | {caught or '**UNCAUGHT**'} | {o.duration:.1f} |"
        )
    return lines


def _case_list(ids: Sequence[str]) -> list[str]:
    lines = []
    for info in (_cases()[i].info for i in ids):
        # A failed SHOULD case is pass-nonstrict and a MAY/INFO one informational: never caught.
        level = "" if info.level is Level.MUST else f" [{info.level.value}: cannot fail]"
        lines.append(f"- {info.id} ({' '.join(info.requirements)}){level}: {info.title}")
    return lines or ["(none)"]


def _per_case(outcomes: Sequence[Outcome]) -> list[str]:
    caught: dict[str, list[str]] = {}
    for o in outcomes:
        for r in o.catchers:
            caught.setdefault(r.info.id, []).append(o.mutant.id)
    return [f"- {case_id} ({len(ms)}): {', '.join(ms)}" for case_id, ms in sorted(caught.items())]


def _report(outcomes: Sequence[Outcome]) -> str:
    """Return the Markdown report: the table, the gaps, the cases no mutant made fail."""
    ever_run = {i for o in outcomes for i in o.ran}
    ever_caught = {r.info.id for o in outcomes for r in o.catchers}
    uncaught = [o.mutant.id for o in outcomes if not o.catchers]
    lines = [
        "# Mutant servers and the cases that catch them",
        "",
        f"{len(outcomes)} mutants, {len(outcomes) - len(uncaught)} caught; timeout scale "
        f"{TIMEOUT_SCALE}, {JOBS} jobs. Each mutant runs the cases that cite its requirements "
        "or sit in their sections (opt-in cases only when named); a case catches it when it "
        "ends fail, error or timing (and passes on the clean server).",
        "",
        *_table(outcomes),
        "",
        "## Uncaught mutants: gaps in the suite",
        "",
        *[f"- {i}: {KNOWN_GAPS.get(i, 'not yet explained')}" for i in uncaught],
        "",
        "## Mutants caught, per case",
        "",
        *_per_case(outcomes),
        "",
        "## Possibly vacuous: run against mutants, never failed",
        "",
        *_case_list(sorted(ever_run - ever_caught)),
        "",
        "## Not run against any mutant (no mutant breaks what they check, or opt-in)",
        "",
        *_case_list(sorted(set(_cases()) - ever_run)),
    ]
    return "\n".join(lines) + "\n"


def test_every_mutant_is_caught_and_the_report_is_written() -> None:
    """Write test-artifacts/mutants.md; only the mutants in KNOWN_GAPS may survive."""
    outcomes = [outcome(m) for m in CATALOGUE]
    REPORT.parent.mkdir(parents=True, exist_ok=True)
    REPORT.write_text(_report(outcomes), encoding="utf-8")
    uncaught = [o.mutant.id for o in outcomes if not o.catchers]
    assert sorted(uncaught) == sorted(KNOWN_GAPS), f"uncaught: {uncaught}; see {REPORT}"
