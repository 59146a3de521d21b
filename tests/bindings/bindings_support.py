"""What the binding tests share: build checks, the broken-behaviour table and its runners.

Every binding test skips when its build outputs are missing, unless OPENAIR_REQUIRE_BINDINGS=1
(set by `make test`), which makes it fail instead. The C++ and Java broken shims implement the
same breaks under the same names, so one table says what must catch each.
"""

from __future__ import annotations

import asyncio
import os
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from openair_conformance.client_cli import conform_client
from openair_conformance.clientmode.engine import ClientRunOptions, run_client
from openair_conformance.clientmode.scenario import load_scenarios
from openair_conformance.model import RunSummary, Verdict
from openair_conformance.reporters.jsonreport import load_report

ROOT = Path(__file__).resolve().parents[2]
JOBS = 4  # scenarios (and broken shims) run at a time: each has its own server and shim


def require(what: str, make: str, *paths: Path, java: bool = False) -> None:
    """Skip (or fail, under OPENAIR_REQUIRE_BINDINGS=1) when a build output is missing."""
    missing = [str(p.relative_to(ROOT)) for p in paths if not p.is_file()]
    if java and shutil.which("java") is None:
        missing.append("java (a Java 17 runtime)")
    if not missing:
        return
    reason = f"{what} not built ({', '.join(missing)} missing): run `{make}`"
    if os.environ.get("OPENAIR_REQUIRE_BINDINGS") == "1":
        pytest.fail(reason, pytrace=False)
    pytest.skip(reason)


@dataclass(frozen=True, slots=True, kw_only=True)
class Break:
    """A broken behaviour, the scenarios that must catch it and one that must still pass."""

    fails: tuple[str, ...]
    evidence: str  # a word the first failing scenario's message contains
    control: str = "CLI-006"


#: --break NAME -> what catches it, for every break a broken shim may offer. The first eight are
#: shim-layer breaks; the others are library faults compiled only into the test builds.
BREAKS: dict[str, Break] = {
    "wrong-trigger": Break(fails=("CLI-004",), evidence="trigger.from"),
    "retrieve-oldest-first": Break(
        fails=("CLI-006",), evidence="messages[0].id", control="CLI-004"
    ),
    "path-swapped": Break(fails=("CLI-002", "CLI-012"), evidence="path is"),
    "phase-as-trigger": Break(fails=("CLI-020",), evidence="trigger.id"),
    "legacy-hidden": Break(fails=("CLI-009",), evidence="legacy is 'false'"),
    "xml-as-text": Break(fails=("CLI-007",), evidence="messages[0].xml"),
    "errors-as-request-failed": Break(fails=("CLI-015",), evidence="CONNECTION_CLOSED"),
    "no-callback": Break(fails=("CLI-003",), evidence="no open callback connection"),
    "lowercase-postedtime": Break(fails=("CLI-019",), evidence="postedtime"),
    "no-posted-time": Break(fails=("CLI-018", "CLI-019"), evidence="carries no postedTime"),
    "no-ack": Break(fails=("CLI-013",), evidence="no answer"),
    "wrong-isresponse": Break(fails=("CLI-013", "CLI-020"), evidence="isresponse"),
    "ping-accept": Break(fails=("CLI-003", "CLI-010"), evidence="RECEIVE_ACCEPT"),
    "noreply-to-legacy": Break(fails=("CLI-009",), evidence="carries a noreply attribute"),
    "pipelining-to-legacy": Break(fails=("CLI-009",), evidence="requests in flight"),
    "crash-on-malformed": Break(fails=("CLI-016",), evidence="closed"),
    "accept-malformed": Break(fails=("CLI-016",), evidence="not RECEIVE_ERROR"),
}

#: The stream and attachment breaks (issue #23): library faults. A binding offers them once
#: its shim has the stream commands (tests add them with `{**breaks_without(), **STREAM_BREAKS}`).
STREAM_BREAKS: dict[str, Break] = {
    "push-no-ack": Break(fails=("CLI-023",), evidence="REQUEST_TIMEOUT"),
    "wait-timeout-error": Break(fails=("CLI-022",), evidence="SAMPLE_UNKNOWN"),
    "push-end-silent": Break(fails=("CLI-024",), evidence="REQUEST_TIMEOUT"),
    "builtins-first": Break(fails=("CLI-021",), evidence="params[0][0]"),
    "registration-samples-lost": Break(fails=("CLI-025",), evidence="REQUEST_TIMEOUT"),
    "attachments-dropped": Break(fails=("CLI-030", "CLI-031"), evidence="attachments"),
}

#: Why a scenario may be not-applicable for every binding alike: the kit's server lacks it.
SERVER_LACKS = "the server does not "  # advertise an extension, or keep attachments


#: The Java broken shim's stream breaks (`--list-streams`; run by test_java_streams.py): the
#: shared ones, and a library fault of its own. A Java push connection takes one sample at a
#: time (it declares no pipelining), so an unacknowledged sample also stalls CLI-024.
JAVA_STREAM_BREAKS: dict[str, Break] = {
    **STREAM_BREAKS,
    "push-no-ack": Break(fails=("CLI-023", "CLI-024"), evidence="REQUEST_TIMEOUT"),
    "add-sample-no-binarysizes": Break(
        fails=("CLI-021", "CLI-022", "CLI-026", "CLI-027", "CLI-028"),
        evidence="FRAME_UNKNOWN_TAG",
    ),
}


def breaks_without(*names: str) -> dict[str, Break]:
    """The table minus the breaks a binding does not offer."""
    return {name: spec for name, spec in BREAKS.items() if name not in names}


def run_real_shim(shim: str, report: Path) -> tuple[int, str, dict[str, Any]]:
    """Run every scenario against `shim` through the CLI; return exit code, output, report."""
    outcome = CliRunner().invoke(
        conform_client, ["--shim", shim, "-j", str(JOBS), "--json", str(report)]
    )
    if not report.is_file():
        pytest.fail(f"no report (exit code {outcome.exit_code}):\n{outcome.output}")
    return outcome.exit_code, outcome.output, load_report(report)


def check_every_scenario_passes(real: tuple[int, str, dict[str, Any]], library: str) -> None:
    """Assert the report covers every scenario, all passing, labelled with `library`."""
    exit_code, output, report = real
    verdicts = {item["id"]: item["verdict"] for item in report["results"]}
    assert list(verdicts) == [s.info.id for s in load_scenarios()]
    lacking = {  # e.g. attachments, until the reference server advertises them
        item["id"]
        for item in report["results"]
        if item["verdict"] == Verdict.NOT_APPLICABLE.value
        and item.get("message", "").startswith(SERVER_LACKS)
    }
    assert {
        id_: v for id_, v in verdicts.items() if v != Verdict.PASS.value and id_ not in lacking
    } == {}, output
    assert exit_code == 0, output
    assert report["server"]["server"] == library
    assert report["server"]["protocol"] == "openair-shim/1"
    assert report["options"]["mode"] == "client"


def run_breaks(
    breaks: Mapping[str, Break], command: Callable[[str], tuple[str, ...]]
) -> dict[str, RunSummary]:
    """Run every break on its catching scenarios and its control, JOBS breaks at a time."""

    async def all_breaks() -> dict[str, RunSummary]:
        window = asyncio.Semaphore(JOBS)

        async def one(name: str, spec: Break) -> RunSummary:
            selected = (*spec.fails, spec.control)
            options = ClientRunOptions(
                shim=command(name), scenario_globs=selected, jobs=len(selected)
            )
            async with window:
                return await run_client(options)

        summaries = await asyncio.gather(*(one(n, s) for n, s in breaks.items()))
        return dict(zip(breaks, summaries, strict=True))

    return asyncio.run(all_breaks())


def check_break(spec: Break, summary: RunSummary) -> None:
    """Assert exactly the expected scenarios failed, with evidence, and the control passed."""
    results = {r.info.id: r for r in summary.results}
    failed = sorted(id_ for id_, r in results.items() if r.verdict is Verdict.FAIL)
    assert failed == sorted(spec.fails), {id_: r.message for id_, r in results.items()}
    first = results[spec.fails[0]]
    assert spec.evidence in first.message, first.message
    assert first.divergence is not None and 0 <= first.divergence < len(first.trace)
    control = results[spec.control]
    assert control.verdict is Verdict.PASS, control.message  # the break is narrow
