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

import re
import shutil
import subprocess
import zipfile
from pathlib import Path
from typing import Any

import pytest
from bindings_support import (
    ROOT,
    breaks_without,
    check_break,
    check_every_scenario_passes,
    require,
    run_breaks,
    run_real_shim,
)

from openair_conformance.model import RunSummary

JAVA_DIR = ROOT / "bindings" / "java"
TARGET = JAVA_DIR / "target"
LIBRARY = TARGET / "openair.jar"
SHIM = TARGET / "openair-shim.jar"
BROKEN_SHIM = TARGET / "openair-shim-broken.jar"

BREAKS = breaks_without("pipelining-to-legacy")  # needs a second seam in main code


def java() -> str:
    """The `java` launcher (the jars need Java 17)."""
    return shutil.which("java") or "java"


def _require(*paths: Path) -> None:
    require("Java binding", "make java", *paths, java=True)


# -- (a) the real shim passes every scenario --------------------------------------------------


@pytest.fixture(scope="module")
def real_report(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, str, dict[str, Any]]:
    _require(SHIM, LIBRARY)
    report = tmp_path_factory.mktemp("java-shim") / "java.json"
    return run_real_shim(f"{java()} -jar {SHIM}", report)


def test_the_java_shim_passes_every_scenario(real_report: tuple[int, str, dict[str, Any]]) -> None:
    check_every_scenario_passes(real_report, "openair-java 0.1.0")


# -- (b) every deliberately broken behaviour is caught ----------------------------------------


def broken_shim(name: str) -> tuple[str, ...]:
    """The command line of the Java shim with behaviour `name` broken."""
    return (java(), "-jar", str(BROKEN_SHIM), "--break", name)


@pytest.fixture(scope="module")
def broken_runs() -> dict[str, RunSummary]:
    """Run every break on its catching scenarios and its control, JOBS breaks at a time."""
    _require(BROKEN_SHIM, LIBRARY)
    return run_breaks(BREAKS, broken_shim)


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
    check_break(BREAKS[name], broken_runs[name])


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
