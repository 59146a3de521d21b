"""The Java binding against the client-conformance kit, and deliberately broken Java shims.

(a) `openair conform-client --shim "java -jar bindings/java/target/openair-shim.jar"` passes
    every scenario.
(b) `java -jar bindings/java/target/openair-shim-broken.jar --break NAME` (test only: built from
    src/test/java, never part of openair.jar or openair-shim.jar) fails exactly the scenarios
    listed in `BREAKS` among those it runs, and passes a control scenario the break does not
    touch. Shim-layer breaks rewrite the shim's commands or answers; library breaks
    (org.openair.internal.FrameFaults) rewrite what the library sends through a package-private
    test seam that the library never sets.

The jars come from `make java` (or `make test-java`). When they are missing the tests skip,
unless OPENAIR_REQUIRE_BINDINGS=1 (set by `make test`), which makes them fail.
"""

from __future__ import annotations

import asyncio
import os
import re
import shutil
import subprocess
import zipfile
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
JAVA_DIR = ROOT / "bindings" / "java"
TARGET = JAVA_DIR / "target"
LIBRARY = TARGET / "openair.jar"
SHIM = TARGET / "openair-shim.jar"
BROKEN_SHIM = TARGET / "openair-shim-broken.jar"

JOBS = 4  # scenarios (and broken shims) run at a time: each has its own server and shim


def java() -> str:
    """The `java` launcher (the jars need Java 17)."""
    return shutil.which("java") or "java"


@dataclass(frozen=True, slots=True, kw_only=True)
class Break:
    """A broken behaviour, the scenarios that must catch it and one that must still pass."""

    fails: tuple[str, ...]
    evidence: str  # a word the first failing scenario's message contains
    control: str = "CLI-006"


#: --break NAME -> what catches it. The first eight are shim-layer breaks (BrokenShimMain); the
#: others are library faults (FrameFaults; noreply-to-legacy also marks the post in the shim).
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
    "crash-on-malformed": Break(fails=("CLI-016",), evidence="closed"),
    "accept-malformed": Break(fails=("CLI-016",), evidence="not RECEIVE_ERROR"),
}


def _require(*paths: Path) -> None:
    """Skip (or fail, under OPENAIR_REQUIRE_BINDINGS=1) when a Java build output is missing."""
    missing = [str(p.relative_to(ROOT)) for p in paths if not p.is_file()]
    if shutil.which("java") is None:
        missing.append("java (a Java 17 runtime)")
    if not missing:
        return
    reason = f"Java binding not built ({', '.join(missing)} missing): run `make java`"
    if os.environ.get("OPENAIR_REQUIRE_BINDINGS") == "1":
        pytest.fail(reason, pytrace=False)
    pytest.skip(reason)


# -- (a) the real shim passes every scenario --------------------------------------------------


@pytest.fixture(scope="module")
def real_report(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, str, dict[str, Any]]:
    _require(SHIM, LIBRARY)
    report = tmp_path_factory.mktemp("java-shim") / "java.json"
    shim = f"{java()} -jar {SHIM}"
    outcome = CliRunner().invoke(
        conform_client, ["--shim", shim, "-j", str(JOBS), "--json", str(report)]
    )
    return outcome.exit_code, outcome.output, load_report(report)


def test_the_java_shim_passes_every_scenario(real_report: tuple[int, str, dict[str, Any]]) -> None:
    exit_code, output, report = real_report
    verdicts = {item["id"]: item["verdict"] for item in report["results"]}
    assert list(verdicts) == [s.info.id for s in load_scenarios()]
    assert {id_: v for id_, v in verdicts.items() if v != Verdict.PASS.value} == {}, output
    assert exit_code == 0, output


def test_the_report_names_the_java_library(real_report: tuple[int, str, dict[str, Any]]) -> None:
    _, _, report = real_report
    assert report["server"]["server"] == "openair-java 0.1.0"
    assert report["server"]["protocol"] == "openair-shim/1"
    assert report["options"]["mode"] == "client"


# -- (b) every deliberately broken behaviour is caught ----------------------------------------


def broken_shim(name: str) -> tuple[str, ...]:
    """The command line of the Java shim with behaviour `name` broken."""
    return (java(), "-jar", str(BROKEN_SHIM), "--break", name)


@pytest.fixture(scope="module")
def broken_runs() -> dict[str, RunSummary]:
    """Run every break on its catching scenarios and its control, JOBS breaks at a time."""
    _require(BROKEN_SHIM, LIBRARY)

    async def all_breaks() -> dict[str, RunSummary]:
        window = asyncio.Semaphore(JOBS)

        async def one(name: str, spec: Break) -> RunSummary:
            selected = (*spec.fails, spec.control)
            options = ClientRunOptions(
                shim=broken_shim(name), scenario_globs=selected, jobs=len(selected)
            )
            async with window:
                return await run_client(options)

        summaries = await asyncio.gather(*(one(n, s) for n, s in BREAKS.items()))
        return dict(zip(BREAKS, summaries, strict=True))

    return asyncio.run(all_breaks())


def test_the_broken_shim_offers_exactly_the_listed_breaks() -> None:
    _require(BROKEN_SHIM, LIBRARY)
    listed = subprocess.run(
        [java(), "-jar", str(BROKEN_SHIM), "--list"],
        capture_output=True, text=True, check=True, timeout=30,
    )  # fmt: skip
    assert sorted(listed.stdout.split()) == sorted(BREAKS)
    assert len(BREAKS) >= 8
    unknown = subprocess.run(
        [*broken_shim("no-such-break")], capture_output=True, text=True, timeout=30
    )
    assert unknown.returncode == 2 and "usage" in unknown.stderr


@pytest.mark.parametrize("name", sorted(BREAKS))
def test_a_broken_behaviour_fails_its_scenarios(
    name: str, broken_runs: dict[str, RunSummary]
) -> None:
    spec = BREAKS[name]
    summary = broken_runs[name]
    results = {r.info.id: r for r in summary.results}
    failed = sorted(id_ for id_, r in results.items() if r.verdict is Verdict.FAIL)
    assert failed == sorted(spec.fails), {id_: r.message for id_, r in results.items()}
    first = results[spec.fails[0]]
    assert spec.evidence in first.message, first.message
    assert first.divergence is not None and 0 <= first.divergence < len(first.trace)
    control = results[spec.control]
    assert control.verdict is Verdict.PASS, control.message  # the break is narrow


# -- (c) the library carries no fault ---------------------------------------------------------


def test_the_library_jars_carry_no_fault() -> None:
    _require(LIBRARY, SHIM, BROKEN_SHIM)
    broken = set(zipfile.ZipFile(BROKEN_SHIM).namelist())
    assert "org/openair/internal/FrameFaults.class" in broken  # so the checks below can fail
    for jar in (LIBRARY, SHIM):
        with zipfile.ZipFile(jar) as archive:
            names = archive.namelist()
            assert not [n for n in names if "FrameFaults" in n or "BrokenShim" in n], jar
            classes = b"".join(archive.read(n) for n in names if n.endswith(".class"))
        assert b"lowercase-postedtime" not in classes and b"no-posted-time" not in classes


def test_only_test_code_sets_the_seam() -> None:
    """The library declares its test seam (Session.tap) but never assigns it."""
    assigns = re.compile(r"\btap\s*=[^=]")
    main = JAVA_DIR / "src" / "main" / "java"
    setters = [p for p in main.rglob("*.java") if assigns.search(p.read_text(encoding="utf-8"))]
    assert setters == []
    faults = (
        JAVA_DIR / "src" / "test" / "java" / "org" / "openair" / "internal" / "FrameFaults.java"
    )
    assert "Session.tap = " in faults.read_text(encoding="utf-8")
