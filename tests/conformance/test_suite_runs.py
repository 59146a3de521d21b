"""The late-case rerun of tests/suite_runs.py, against the reference server.

XSTREAM-004 creates a named stream; its first run leaves the name held by the server. Made late
(TIMING) by a wrapper around the engine's `run`, it is run again alone against the same server:
the rerun must not collide with the first run's names (a clean-clone CI run judged it
inconclusive, "the name ... is already in use", when the rerun reused the run id).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest
import suite_runs
from server_thread import ReferenceServer

from openair_conformance.engine import RunOptions
from openair_conformance.engine import run as real_run
from openair_conformance.model import RunSummary, Verdict
from openair_conformance.registry import all_cases

CASE = "XSTREAM-004"


def test_a_late_case_is_rerun_alone_under_a_new_run_id(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[RunOptions] = []

    async def first_late(options: RunOptions, cases: Any = None) -> RunSummary:
        calls.append(options)
        summary = await real_run(options, cases=cases)
        if len(calls) > 1:
            return summary
        assert [r.verdict for r in summary.results] == [Verdict.PASS]
        late = tuple(dataclasses.replace(r, verdict=Verdict.TIMING) for r in summary.results)
        return dataclasses.replace(summary, results=late)

    monkeypatch.setattr(suite_runs, "run", first_late)
    server = ReferenceServer()
    try:
        options = RunOptions(target=("127.0.0.1", server.port), jobs=4, case_globs=(CASE,))
        _, results = suite_runs.run_suite(options, [c for c in all_cases() if c.info.id == CASE])
    finally:
        server.stop()
    assert len(calls) == 2
    again = calls[1]
    assert (again.jobs, again.case_globs) == (1, (CASE,))
    assert again.run_id != options.run_id
    assert [(r.info.id, r.verdict, r.message) for r in results] == [(CASE, Verdict.PASS, "")]


def test_nothing_is_rerun_when_no_case_is_late(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[RunOptions] = []

    async def counted(options: RunOptions, cases: Any = None) -> RunSummary:
        calls.append(options)
        return await real_run(options, cases=cases)

    monkeypatch.setattr(suite_runs, "run", counted)
    server = ReferenceServer()
    try:
        # Wide deadlines: on a loaded machine the case could be late for real, and then its
        # rerun would be right; what is tested is that an on-time case is not run again.
        options = RunOptions(
            target=("127.0.0.1", server.port), case_globs=(CASE,), timeout_scale=10.0
        )
        _, results = suite_runs.run_suite(options, [c for c in all_cases() if c.info.id == CASE])
    finally:
        server.stop()
    assert len(calls) == 1
    assert [r.verdict for r in results] == [Verdict.PASS]
