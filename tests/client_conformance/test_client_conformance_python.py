"""The Python shim passes every scenario; its reports validate; two bindings compare in a matrix."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, cast

import lxml.html
import pytest
from click.testing import CliRunner
from client_conformance_support import PYTHON_SHIM, broken_shim, result, run
from lxml import etree

from openair_conformance.cli import conform
from openair_conformance.clientmode.scenario import load_scenarios
from openair_conformance.model import Reporter, RunSummary, Verdict
from openair_conformance.reporters.html import HtmlReporter
from openair_conformance.reporters.jsonreport import (
    JsonReporter,
    decode_result,
    load_report,
    report_schema,
)
from openair_conformance.reporters.junit import JUnitReporter

_JUNIT_XSD = (
    Path(__file__).resolve().parents[2] / "conformance/openair_conformance/schemas/junit.xsd"
)
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True)
jsonschema: Any = importlib.import_module("jsonschema")  # a test extra without stubs


def _nodes(node: Any, path: str) -> list[Any]:
    """The nodes an XPath selects (lxml's stubs type xpath() as any XPath result)."""
    return cast(list[Any], node.xpath(path))


def _texts(node: Any, path: str) -> list[str]:
    return [str(n.text_content()) for n in _nodes(node, path)]


@dataclass(frozen=True, slots=True, kw_only=True)
class PythonRun:
    summary: RunSummary
    json: Path
    html: Path
    junit: Path


@pytest.fixture(scope="module")
def python_run(tmp_path_factory: pytest.TempPathFactory) -> PythonRun:
    out = tmp_path_factory.mktemp("python-shim")
    paths = {name: out / f"python.{name}" for name in ("json", "html", "xml")}
    reporters: list[Reporter] = [
        JsonReporter(paths["json"]),
        HtmlReporter(paths["html"]),
        JUnitReporter(paths["xml"]),
    ]
    summary = run(PYTHON_SHIM, reporters=reporters, jobs=4)
    return PythonRun(summary=summary, json=paths["json"], html=paths["html"], junit=paths["xml"])


def test_the_python_shim_passes_every_scenario(python_run: PythonRun) -> None:
    shipped = [s.info.id for s in load_scenarios()]
    assert len(shipped) >= 15
    assert [r.info.id for r in python_run.summary.results] == shipped
    problems = {
        r.info.id: f"{r.verdict.value}: {r.message}"
        for r in python_run.summary.results
        if r.verdict is not Verdict.PASS and not _server_lacks_it(r.verdict, r.message)
    }
    assert problems == {}


def _server_lacks_it(verdict: Verdict, message: str) -> bool:
    """A scenario of an extension the reference server does not advertise (attachments)."""
    return verdict is Verdict.NOT_APPLICABLE and message.startswith("the server does not ")


def test_the_wakeup_latency_is_measured(python_run: PythonRun) -> None:
    names = dict(python_run.summary.latencies)
    assert names["post_to_wakeup_samples"] >= 5
    assert 0 < names["post_to_wakeup_p50_ms"] <= names["post_to_wakeup_p99_ms"]
    wakeup = result(python_run.summary, "CLI-004")
    assert [name for name, _ in wakeup.measurements] == ["post_to_wakeup_ms"]


def test_the_json_report_validates_and_names_the_library(python_run: PythonRun) -> None:
    data = load_report(python_run.json)  # the kit's own check against the schema
    jsonschema.Draft202012Validator(report_schema()).validate(data)  # and an independent one
    assert data["server"]["server"] == f"openair-python {metadata.version('openair-kit')}"
    assert data["server"]["protocol"] == "openair-shim/1"
    assert data["options"]["mode"] == "client"
    assert data["target"] == " ".join(PYTHON_SHIM)
    decoded = [decode_result(item) for item in data["results"]]
    assert [r.info for r in decoded] == [r.info for r in python_run.summary.results]
    repro = decoded[0].repro
    assert repro.startswith("openair conform-client --shim ") and repro.endswith("CLI-001")


def test_the_junit_report_validates(python_run: PythonRun) -> None:
    schema = etree.XMLSchema(etree.parse(str(_JUNIT_XSD), _PARSER))
    doc = etree.parse(str(python_run.junit), _PARSER)
    schema.assertValid(doc)
    assert len(_nodes(doc.getroot(), "//testcase")) == len(python_run.summary.results)


def test_the_html_report_shows_the_wire_evidence(python_run: PythonRun) -> None:
    page = lxml.html.fromstring(python_run.html.read_bytes())
    (text,) = _texts(page, "//article[@id='case-CLI-003']")
    assert "RECEIVE_NAME_NOTIFICATION" in text  # the captured Receive frame is in the trace
    assert "callback#" in text


def test_the_matrix_report_compares_two_bindings(python_run: PythonRun, tmp_path: Path) -> None:
    broken_json = tmp_path / "broken.json"
    summary = run(
        broken_shim("ping-accept"), ["CLI-004", "CLI-010"], reporters=[JsonReporter(broken_json)]
    )
    assert result(summary, "CLI-010").verdict is Verdict.FAIL
    output = tmp_path / "matrix.html"
    outcome = CliRunner().invoke(
        conform, ["report", str(python_run.json), str(broken_json), "-o", str(output)]
    )
    assert outcome.exit_code == 0, outcome.output
    page = lxml.html.fromstring(output.read_bytes())
    head = _texts(page, "//table[@id='compare-table']/thead/tr/th")
    version = metadata.version("openair-kit")
    assert head[3:] == [f"openair-python {version}", f"openair-python-broken-ping-accept {version}"]
    rows = {
        _texts(tr, "td[1]")[0]: _texts(tr, "td")[3:]
        for tr in _nodes(page, "//table[@id='compare-table']/tbody/tr")
    }
    assert rows["CLI-010"] == ["pass", "fail"]
    assert rows["CLI-004"] == ["pass", "pass"]
    assert rows["CLI-001"] == ["pass", "—"]  # not run with the broken shim
