"""The client-conformance matrix: the Python, C++ and Java bindings side by side, all passing.

`openair conform-client --json` runs once per binding's shim (the three at a time, as
subprocesses), then `openair conform report py.json cpp.json java.json -o matrix.html` renders
the comparison page. The page is written into the test's temporary folder and copied to
test-artifacts/client-matrix.html (git-ignored) for people to look at.

The C++ and Java shims come from `make cpp` and `make java`. When they are missing the test
skips, unless OPENAIR_REQUIRE_BINDINGS=1 (set by `make test`), which makes it fail.
"""

from __future__ import annotations

import asyncio
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import lxml.html
import pytest
from bindings_support import require

from openair.server.aio.app import DEFAULT_EXTENSIONS
from openair_conformance.clientmode.scenario import Scenario, load_scenarios
from openair_conformance.reporters.jsonreport import load_report

ROOT = Path(__file__).resolve().parents[2]
CPP_SHIM = ROOT / "bindings" / "cpp" / "build" / "openair-shim"
JAVA_SHIM = ROOT / "bindings" / "java" / "target" / "openair-shim.jar"
ARTIFACT = ROOT / "test-artifacts" / "client-matrix.html"
OPENAIR = Path(sys.executable).with_name("openair")  # the kit's console script, beside python

JOBS = 3  # scenarios per binding at a time; the three bindings run at once
TIMEOUT = 300.0  # one conform-client run; a hang fails instead of blocking


def _require(*paths: Path) -> None:
    require("bindings", "make cpp java", *paths, java=True)


@dataclass(frozen=True, slots=True, kw_only=True)
class Binding:
    """One column: the shim command line and the label its report must carry."""

    key: str
    shim: str
    label: str


def bindings() -> tuple[Binding, ...]:
    java = shutil.which("java") or "java"
    python = f"{sys.executable} -m openair.client.shim"
    return (
        Binding(key="python", shim=python, label="openair-python"),
        Binding(key="cpp", shim=str(CPP_SHIM), label="openair-cpp"),
        Binding(key="java", shim=f"{java} -jar {JAVA_SHIM}", label="openair-java"),
    )


async def openair(*args: str) -> tuple[int, str]:
    """Run the `openair` command line; return its exit code and output."""
    proc = await asyncio.create_subprocess_exec(
        str(OPENAIR), *args, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT
    )
    try:
        out, _ = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
    return proc.returncode or 0, out.decode("utf-8", "replace")


async def conform_all(folder: Path) -> list[tuple[int, str]]:
    """conform-client for every binding at once, each writing `folder/KEY.json`."""
    runs = (
        openair("conform-client", "--shim", b.shim, "-j", str(JOBS), "--json", str(report))
        for b in bindings()
        for report in [folder / f"{b.key}.json"]
    )
    return list(await asyncio.gather(*runs))


@dataclass(frozen=True, slots=True, kw_only=True)
class Matrix:
    """The comparison page, read back: column labels and one row of cell classes per case."""

    labels: list[str]
    rows: dict[str, list[str]]  # scenario ID -> the class of each binding's cell


TABLE = "//table[@id='compare-table']"


def _strings(root: lxml.html.HtmlElement, path: str) -> list[str]:
    found = root.xpath(path)
    assert isinstance(found, list), found
    return [str(item) for item in found]


def read_matrix(page: Path) -> Matrix:
    """Read the cases table of a comparison page (columns after ID, section and title)."""
    root = lxml.html.fromstring(page.read_bytes())
    labels = _strings(root, f"{TABLE}/thead/tr/th[position() > 3]/text()")
    ids = _strings(root, f"{TABLE}/tbody/tr/td[1]/text()")
    rows = {
        id_: _strings(root, f"{TABLE}/tbody/tr[td[1] = '{id_}']/td[position() > 3]/@class")
        for id_ in ids
    }
    return Matrix(labels=labels, rows=rows)


@pytest.fixture(scope="module")
def matrix(tmp_path_factory: pytest.TempPathFactory) -> Matrix:
    _require(CPP_SHIM, JAVA_SHIM)
    folder = tmp_path_factory.mktemp("client-matrix")
    runs = asyncio.run(conform_all(folder))
    for binding, (code, output) in zip(bindings(), runs, strict=True):
        assert code == 0, f"{binding.key}: conform-client exited {code}\n{output}"
        assert load_report(folder / f"{binding.key}.json")["options"]["mode"] == "client"
    page = folder / "matrix.html"
    reports = [str(folder / f"{b.key}.json") for b in bindings()]
    code, output = asyncio.run(openair("conform", "report", *reports, "-o", str(page)))
    assert code == 0, output
    ARTIFACT.parent.mkdir(exist_ok=True)
    shutil.copyfile(page, ARTIFACT)
    return read_matrix(page)


def test_the_matrix_has_one_column_per_library(matrix: Matrix) -> None:
    assert [label.split(" ")[0] for label in matrix.labels] == [b.label for b in bindings()]


def _server_lacks(scenario: Scenario) -> bool:
    """Whether the scenario needs an extension the reference server does not advertise."""
    needed = {step.get("feature") for step in scenario.steps if step.kind == "require"}
    return bool(needed - DEFAULT_EXTENSIONS)


def test_every_binding_passes_every_scenario(matrix: Matrix) -> None:
    scenarios = load_scenarios()
    assert sorted(matrix.rows) == sorted(s.info.id for s in scenarios)
    # Not-applicable alike for all three when the server lacks the feature (attachments).
    lacking = {s.info.id for s in scenarios if _server_lacks(s)}
    failing = {
        id_: cells
        for id_, cells in matrix.rows.items()
        if cells != ["v-pass"] * 3 and not (id_ in lacking and cells == ["v-not-applicable"] * 3)
    }
    assert failing == {}
