"""The Java binding's stream breaks: each deliberately broken stream behaviour is caught.

`java -jar bindings/java/target/openair-shim-broken.jar --break NAME` for every NAME of
`--list-streams` (test only: built from src/test/java) fails exactly the scenarios that
`JAVA_STREAM_BREAKS` lists among those it runs, and passes the control scenario: the shared
stream breaks of `STREAM_BREAKS` (the C++ shim's too) and `add-sample-no-binarysizes`. Shim-layer
breaks rewrite stream commands or answers (`wait-timeout-error`, `push-end-silent`,
`builtins-first`, `registration-samples-lost`); library faults rewrite what the library sends
(`push-no-ack`: pushed samples never acknowledged; `add-sample-no-binarysizes`: ADD_SAMPLE's
chunk without `binarysizes`). That the real shim passes every stream scenario is checked by
test_java_binding.py, which runs all scenarios.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from bindings_support import JAVA_STREAM_BREAKS, ROOT, check_break, require, run_breaks

from openair_conformance.model import RunSummary

TARGET = ROOT / "bindings" / "java" / "target"
LIBRARY = TARGET / "openair.jar"
BROKEN_SHIM = TARGET / "openair-shim-broken.jar"


def _java() -> str:
    return shutil.which("java") or "java"


def _require(*paths: Path) -> None:
    require("Java binding", "make java", *paths, java=True)


def _broken_shim(name: str) -> tuple[str, ...]:
    return (_java(), "-jar", str(BROKEN_SHIM), "--break", name)


@pytest.fixture(scope="module")
def stream_break_runs() -> dict[str, RunSummary]:
    """Run every stream break on its catching scenarios and its control."""
    _require(BROKEN_SHIM, LIBRARY)
    return run_breaks(JAVA_STREAM_BREAKS, _broken_shim)


def test_the_broken_shim_lists_exactly_the_stream_breaks() -> None:
    _require(BROKEN_SHIM, LIBRARY)
    listed = subprocess.run(
        [_java(), "-jar", str(BROKEN_SHIM), "--list-streams"],
        capture_output=True,
        text=True,
        check=True,
        timeout=30,
    )
    assert sorted(listed.stdout.split()) == sorted(JAVA_STREAM_BREAKS)
    core = subprocess.run(
        [_java(), "-jar", str(BROKEN_SHIM), "--list"],
        capture_output=True,
        text=True,
        check=True,
        timeout=30,
    )
    assert not set(core.stdout.split()) & set(JAVA_STREAM_BREAKS)


@pytest.mark.parametrize("name", sorted(JAVA_STREAM_BREAKS))
def test_a_broken_stream_behaviour_fails_its_scenarios(
    name: str, stream_break_runs: dict[str, RunSummary]
) -> None:
    check_break(JAVA_STREAM_BREAKS[name], stream_break_runs[name])
