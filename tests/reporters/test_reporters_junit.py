"""The JUnit reporter: valid against schemas/junit.xsd, counts right, verdicts mapped, text safe."""

from __future__ import annotations

from pathlib import Path

import xmlschema
from lxml import etree
from reporters_support import FAILING_ID, SYNTHETIC, Artifacts

from openair_conformance.model import Verdict
from openair_conformance.reporters.junit import junit_kind

XSD = (
    Path(__file__).resolve().parents[2]
    / "conformance"
    / "openair_conformance"
    / "schemas"
    / "junit.xsd"
)
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True)


def _doc(artifacts: Artifacts) -> etree._Element:
    return etree.parse(str(artifacts.junit), _PARSER).getroot()


def _cases(root: etree._Element) -> dict[str, etree._Element]:
    return {tc.get("name", "").split(" ")[0]: tc for tc in root.iter("testcase")}


def test_the_report_is_valid_against_the_xsd_with_both_validators(artifacts: Artifacts) -> None:
    schema = etree.XMLSchema(etree.parse(str(XSD), _PARSER))
    document = etree.parse(str(artifacts.junit), _PARSER)
    assert schema.validate(document), schema.error_log
    xmlschema.XMLSchema(str(XSD)).validate(str(artifacts.junit))


def test_the_xsd_rejects_what_junit_readers_reject() -> None:
    schema = etree.XMLSchema(etree.parse(str(XSD), _PARSER))
    bad = [
        "<testsuites><testsuite tests='1'/></testsuites>",  # no name
        "<testsuites><testsuite name='a' tests='-1'/></testsuites>",
        "<testsuite name='a' tests='1'><testcase/></testsuite>",  # testcase without name
        "<testsuite name='a' tests='1'><testcase name='x'><system-out/><failure/></testcase>"
        "</testsuite>",  # failure after system-out
        "<testsuite name='a' tests='1' timestamp='2026-01-01 10:00:00'/>",
    ]
    for text in bad:
        assert not schema.validate(etree.fromstring(text)), text


def test_one_suite_per_section_and_the_counts_add_up(artifacts: Artifacts) -> None:
    root = _doc(artifacts)
    suites = root.findall("testsuite")
    sections = sorted({case.info.section for case in SYNTHETIC})
    assert [s.get("package") for s in suites] == sections
    assert suites[0].get("name", "").startswith("6.7 PING")
    for suite in suites:
        cases = suite.findall("testcase")
        assert {tc.get("classname") for tc in cases} == {suite.get("package")}
        assert int(suite.get("tests", "")) == len(cases)
        for kind, attr in (("failure", "failures"), ("error", "errors"), ("skipped", "skipped")):
            assert int(suite.get(attr, "")) == sum(1 for tc in cases if tc.find(kind) is not None)
    summary = artifacts.summary
    assert int(root.get("tests", "")) == summary.total == len(SYNTHETIC)
    failures = sum(
        summary.count(v) for v in (Verdict.FAIL, Verdict.TIMING, Verdict.UNEXPECTED_PASS)
    )
    assert int(root.get("failures", "")) == failures
    assert int(root.get("errors", "")) == summary.count(Verdict.ERROR)


def test_each_verdict_is_mapped(artifacts: Artifacts) -> None:
    testcases = _cases(_doc(artifacts))
    for result in artifacts.summary.results:
        element = testcases[result.info.id]
        assert element.get("name") == f"{result.info.id} {result.info.title}"
        kind = junit_kind(result.verdict)
        children = [c.tag for c in element if c.tag != "system-out"]
        assert children == ([] if kind == "passed" else [kind]), result.verdict
        if kind in ("failure", "error"):
            assert element[0].get("type") == result.verdict.value
        if kind == "skipped":
            assert element[0].get("message", "").startswith(result.verdict.value)
    assert junit_kind(Verdict.TIMING) == "failure" and junit_kind(Verdict.ERROR) == "error"
    assert junit_kind(Verdict.NOT_APPLICABLE) == "skipped"
    out = testcases["SYN-009"].findtext("system-out") or ""
    assert "expected failure, counted as passed" in out and "known bug" in out


def test_properties_name_the_target_and_the_server(artifacts: Artifacts) -> None:
    suite = _doc(artifacts).find("testsuite")
    assert suite is not None
    props = {p.get("name"): p.get("value") for p in suite.iter("property")}
    started = artifacts.events[0]
    assert props["target"] == getattr(started, "target", None)
    assert props["server"] == "fake/0" and props["extensions"] == "pipelining"
    assert props["option.jobs"] == "3"


def test_the_failure_carries_the_evidence_as_text(artifacts: Artifacts) -> None:
    failing = _cases(_doc(artifacts))[FAILING_ID]
    failure = failing.find("failure")
    assert failure is not None
    assert failure.get("message") == "PING was answered with a hostile frame"
    assert "PING_SUCCESS (OA-SESS-10)" in (failure.text or "")
    out = failing.findtext("system-out") or ""
    assert "OA-SESS-10 (MUST): A PING MUST be answered" in out
    assert f"repro: openair conform {artifacts.events[0].target}" in out  # type: ignore[union-attr]
    # The hostile frame is text: the markup is escaped by the serialiser, controls neutralised.
    assert "<script>alert('x')</script>" in out and "\\x1b[31m" in out and "\x1b" not in out
    assert not list(failing.iter("script"))
    assert "step 5" not in out and "step 6" in out  # the excerpt: the last 10 entries


def test_the_mapping_is_the_documented_one() -> None:
    documented = {
        "passed": {"pass", "pass-nonstrict", "informational", "expected-failure"},
        "failure": {"fail", "timing", "unexpected-pass"},
        "error": {"error"},
        "skipped": {"not-applicable", "inconclusive"},
    }
    assert {v.value: junit_kind(v) for v in Verdict} == {
        value: kind for kind, values in documented.items() for value in values
    }
