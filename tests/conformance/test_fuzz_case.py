"""FUZZ-001, the stateful routing fuzzer: its model, and the case against good and broken servers.

The model is checked against the wildcard vectors and small routing examples written from the
spec. The case runs in-process against the reference server (in a background thread): it passes
with a small budget, `--replay SEED` repeats the same steps, and a server made to ignore cc, or
to match case-sensitively, is caught with the seed and a shrunk step list in the message.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from test_engine_support import ServerThread

from openair_conformance import fuzz
from openair_conformance.cli import conform
from openair_conformance.engine import RunOptions, run
from openair_conformance.fuzz import parse_seed
from openair_conformance.fuzz.model import (
    RoutingModel,
    Stored,
    Trigger,
    board_matches,
    cc_names,
    glob_matches,
)
from openair_conformance.model import CaseResult, Verdict
from openair_conformance.registry import get_case

app = pytest.importorskip("openair.server.aio.app")
router = pytest.importorskip("openair.server.core.router")

VECTORS = Path(__file__).resolve().parents[2] / "spec" / "vectors" / "wildcards" / "wildcards.json"


# -- the model ----------------------------------------------------------------------------------


def test_model_matcher_agrees_with_the_wildcard_vectors() -> None:
    rows = json.loads(VECTORS.read_text(encoding="utf-8"))["rows"]
    judged = [r for r in rows if r["expected"] in ("match", "nomatch")]
    expect = {"match": True, "nomatch": False}
    wrong = [r for r in judged if glob_matches(r["pattern"], r["type"]) != expect[r["expected"]]]
    assert len(judged) > 800
    assert wrong == []


def test_model_reads_trigger_from_and_cc_as_the_spec_says() -> None:
    assert board_matches(None, "WB1") and board_matches("any", "WB2") and board_matches("", "X")
    assert board_matches("wb1", "WB1") and not board_matches("WB*", "WB1")  # OA-TRIG-2
    assert cc_names(" A ; B;;\tC ;") == {"A", "B", "C"}  # OA-CC-1
    assert cc_names("A,B") == {"A,B"}


def _stored(n: int, type_: str, sender: str = "P", board: str = "WB1") -> Stored:
    return Stored(id=f"id{n}", type=type_, sender=sender, board=board)


def test_model_wakes_by_trigger_cc_and_self_rules() -> None:
    model = RoutingModel()
    for name in ("A", "B", "C"):
        model.bind(name)
    model.subscribe("A", (Trigger(pattern="T.*", board="wb1"), Trigger(pattern="*")), self_ok=False)
    model.subscribe("B", (Trigger(pattern="T.X", board="WB2"),), self_ok=True)
    # A: first matching trigger; B: cc only (its trigger is for WB2); C: not named.
    assert model.post(_stored(1, "T.X"), "B;Nobody") == {"A": "T.*", "B": ""}
    # The poster's own triggers do not fire unless allowed, but cc still wakes it.
    assert model.post(_stored(2, "T.X", sender="A"), "") == {}
    assert model.post(_stored(3, "T.X", sender="A"), "A") == {"A": ""}
    assert model.post(_stored(4, "T.X", sender="B", board="WB2"), "") == {"A": "*", "B": "T.X"}
    # A new registration replaces the old one as a whole; an unbound module is never woken.
    model.subscribe("A", (), self_ok=False)
    model.unbind("B")
    assert model.post(_stored(5, "T.X"), "A;B") == {"A": ""}


def test_model_retrieves_newest_first_with_latest_and_sender() -> None:
    model = RoutingModel()
    for n, (type_, sender) in enumerate([("R.A", "P"), ("R.B", "Q"), ("R.A", "Q"), ("X", "P")]):
        model.post(_stored(n, type_, sender=sender), "")
    assert model.retrieve("WB1", "R.*") == ["id2"]  # latest defaults to 1
    assert model.retrieve("WB1", "R.*", latest=0) == ["id2", "id1", "id0"]
    assert model.retrieve("WB1", "r.a", latest=5) == ["id2", "id0"]
    assert model.retrieve("WB1", "*", sender="P", latest=0) == ["id3", "id0"]
    assert model.retrieve("WB2", "*", latest=0) == []


def test_seed_parsing() -> None:
    assert parse_seed("1234") == 1234
    assert parse_seed(" abc ") == "abc"
    assert isinstance(parse_seed(None), int)


def test_the_case_is_registered_serial_and_cites_routing_rules() -> None:
    info = get_case("FUZZ-001").info
    assert info.serial
    assert {"OA-TRIG-1", "OA-CC-2", "OA-WAKE-5", "OA-RET-6", "OA-TRIG-4"} <= set(info.requirements)


# -- the case against servers -------------------------------------------------------------------


@pytest.fixture
def reference() -> Iterator[tuple[str, int]]:
    """A reference server of this test's own (monkeypatches apply to it while the test runs)."""
    options = app.ServerOptions(host="127.0.0.1", port=0, grace_s=0.5)  # a quick stop
    thread = ServerThread(lambda: app.start_server(options))
    yield ("127.0.0.1", thread.port)
    thread.stop()


def _fuzz(target: tuple[str, int], examples: int, replay: str | None = None) -> CaseResult:
    options = RunOptions(
        target=target, case_globs=("FUZZ-001",), fuzz_examples=examples, replay=replay
    )
    summary = asyncio.run(run(options))
    (result,) = summary.results
    return result


def _example_notes(result: CaseResult) -> list[str]:
    return [e.text for e in result.trace if e.direction == "note" and e.text.startswith("example")]


def test_passes_against_the_reference_server(reference: tuple[str, int]) -> None:
    result = _fuzz(reference, 6)
    assert result.verdict == Verdict.PASS, result.message
    assert " --replay " in result.repro and "--fuzz-examples 6" in result.repro
    assert len(_example_notes(result)) >= 6
    assert dict(result.measurements)["fuzz_runs"] >= 6


def test_replay_repeats_the_same_steps(reference: tuple[str, int]) -> None:
    first = _fuzz(reference, 3, replay="1234")
    second = _fuzz(reference, 3, replay="1234")
    other = _fuzz(reference, 3, replay="99")
    assert first.verdict == second.verdict == Verdict.PASS, first.message + second.message
    assert "--replay 1234" in first.repro
    assert _example_notes(first) == _example_notes(second)
    assert any("posts" in note for note in _example_notes(first))
    assert _example_notes(first) != _example_notes(other)  # the seed is used


def _ignore_cc(monkeypatch: pytest.MonkeyPatch) -> None:
    woken = router.Router._woken

    def without_cc(self: Any, board: Any, stored: Any) -> Any:
        return woken(self, board, dataclasses.replace(stored, cc=""))

    monkeypatch.setattr(router.Router, "_woken", without_cc)


def _case_sensitive(monkeypatch: pytest.MonkeyPatch) -> None:
    import openair.protocol.matching

    monkeypatch.setattr(openair.protocol.matching, "ascii_fold", lambda text: text)


@pytest.mark.parametrize("breakage", [_ignore_cc, _case_sensitive], ids=["cc", "case"])
def test_a_broken_server_fails_with_seed_and_steps(
    reference: tuple[str, int], monkeypatch: pytest.MonkeyPatch, breakage: Any
) -> None:
    breakage(monkeypatch)
    monkeypatch.setattr(fuzz, "SHRINK_SECONDS", 3.0)  # a shorter example is not the point here
    result = _fuzz(reference, 25, replay="1234")
    assert result.verdict == Verdict.FAIL, result.message
    assert "seed 1234" in result.message and "--replay 1234" in result.repro
    steps = [line for line in result.message.splitlines() if line.startswith("  ")]
    assert steps and steps[0].startswith("  1. bind m")
    assert any(" posts " in line for line in steps)
    assert "(OA-" in result.expected
    assert any(e.direction == "in" for e in result.trace)  # the shrunk example's frames


def test_cli_runs_the_fuzz_case(reference: tuple[str, int]) -> None:
    address = f"{reference[0]}:{reference[1]}"
    args = [address, "--case", "FUZZ-001", "--fuzz-examples", "3", "--replay", "1234"]
    result = CliRunner().invoke(conform, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "FUZZ-001" in result.output


def test_a_server_that_wakes_nobody_fails_without_shrinking(
    reference: tuple[str, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(router.Router, "_woken", lambda self, board, stored: {})
    result = _fuzz(reference, 25, replay="7")
    assert result.verdict == Verdict.FAIL, result.message
    assert "sync wakeup" in result.message  # the sentinel never came: waiting again is useless
    assert "seed 7; steps so far:" in result.message and "  1. bind m" in result.message
    assert dict(result.measurements)["fuzz_runs"] == 1
