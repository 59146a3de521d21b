"""The JUnit XML reporter, in the Jenkins/Ant form CI servers read (`schemas/junit.xsd`).

One `<testsuite>` per spec section (name "6.7 PING, KEEPALIVE and STATUS", `package` "6.7"),
one `<testcase>` per case (classname = the section, name = "ID title"). Verdicts map as follows:

| verdict | JUnit |
|---|---|
| pass, pass-nonstrict, informational, expected-failure | passed (system-out says which) |
| fail | `<failure type="fail">` |
| timing | `<failure type="timing">` |
| unexpected-pass | `<failure type="unexpected-pass">` |
| error | `<error type="error">` |
| not-applicable, inconclusive | `<skipped>` (the message says which) |

Each suite's `<properties>` name the target, the server and the run options; each testcase's
`<system-out>` holds the verdict note, the requirement sentences, the repro line and the trace
excerpt. The file is written when the reporter is closed; nothing is written when no run started.
"""

from __future__ import annotations

from lxml import etree

from openair_conformance.model import CaseResult, RunStarted, Verdict
from openair_conformance.registry import requirement_sentences
from openair_conformance.reporters._common import (
    FileReporter,
    RunRecord,
    entry_head,
    excerpt,
    first_line,
    format_time,
    safe_text,
    section_key,
    section_label,
)

__all__ = ["JUnitReporter", "junit_document", "junit_kind"]

_FAILURE = frozenset({Verdict.FAIL, Verdict.TIMING, Verdict.UNEXPECTED_PASS})
_SKIPPED = frozenset({Verdict.NOT_APPLICABLE, Verdict.INCONCLUSIVE})
_ENTRY_CHARS = 2000


def junit_kind(verdict: Verdict) -> str:
    """Return how JUnit shows a verdict: "failure", "error", "skipped" or "passed"."""
    if verdict in _FAILURE:
        return "failure"
    if verdict is Verdict.ERROR:
        return "error"
    if verdict in _SKIPPED:
        return "skipped"
    return "passed"


def _text(value: str) -> str:
    return safe_text(value)


def _properties(started: RunStarted | None) -> etree._Element:
    props = etree.Element("properties")
    if started is None:
        return props
    server = started.server
    pairs = [
        ("target", started.target),
        ("started", format_time(started.started)),
        ("server", server.server),
        ("protocol", server.protocol),
        ("legacy", str(server.legacy).lower()),
        ("extensions", " ".join(server.capabilities)),
        ("limits", " ".join(f"{name}={value}" for name, value in server.limits)),
        ("rtt_ms", f"{server.rtt_ms:.3f}"),
    ]
    pairs += [(f"option.{key}", value) for key, value in sorted(started.options.items())]
    for name, value in pairs:
        etree.SubElement(props, "property", name=_text(name), value=_text(value))
    return props


def _system_out(result: CaseResult) -> str:
    lines = [f"verdict: {result.verdict.value}"]
    if result.verdict is Verdict.EXPECTED_FAILURE:
        lines.append("an expected failure, counted as passed: " + result.expectation_reason)
    elif result.verdict in (Verdict.PASS_NONSTRICT, Verdict.INFORMATIONAL):
        lines.append(f"a {result.info.level.value} requirement is not met; counted as passed")
    if result.target_died:
        lines.append("the target died during this case (it stopped answering the liveness probe)")
    if result.rerun_after_restart:
        lines.append("rerun after restart: the first attempt was interrupted by the target's death")
    if result.message:
        lines += ["", result.message]
    lines += ["", "requirements:"]
    lines += [
        f"  {rid} ({level}): {text}" for rid, level, text in requirement_sentences(result.info)
    ]
    lines += ["", f"repro: {result.repro}"]
    start, entries = excerpt(result)
    if entries:
        lines += ["", f"trace #{start}–#{start + len(entries) - 1} of {len(result.trace)}:"]
        for offset, entry in enumerate(entries):
            mark = "▶ " if start + offset == result.divergence else "  "
            text = entry.text[:_ENTRY_CHARS] + ("…" if len(entry.text) > _ENTRY_CHARS else "")
            lines += [mark + entry_head(start + offset, entry), text]
    return _text("\n".join(lines))


def _testcase(result: CaseResult) -> etree._Element:
    info = result.info
    element = etree.Element(
        "testcase",
        classname=info.section,
        name=_text(f"{info.id} {info.title}"),
        time=f"{result.duration:.3f}",
    )
    kind = junit_kind(result.verdict)
    message = _text(first_line(result.message, 500) or result.verdict.value)
    if kind == "skipped":
        etree.SubElement(element, "skipped", message=f"{result.verdict.value}: {message}")
    elif kind in ("failure", "error"):
        child = etree.SubElement(element, kind, message=message, type=result.verdict.value)
        body = [result.message]
        if result.expected:
            body += ["", "allowed / expected:", result.expected]
        child.text = _text("\n".join(body))
    etree.SubElement(element, "system-out").text = _system_out(result)
    return element


def _suite(
    index: int, section: str, cases: list[CaseResult], started: RunStarted | None
) -> etree._Element:
    kinds = [junit_kind(r.verdict) for r in cases]
    suite = etree.Element("testsuite", name=_text(section_label(section)))
    suite.set("tests", str(len(cases)))
    for kind, attribute in (("failure", "failures"), ("error", "errors"), ("skipped", "skipped")):
        suite.set(attribute, str(kinds.count(kind)))
    suite.set("time", f"{sum(r.duration for r in cases):.3f}")
    if started is not None:
        suite.set("timestamp", format_time(started.started).removesuffix("Z"))  # no zone
    suite.set("id", str(index))
    suite.set("package", section)
    suite.append(_properties(started))
    for result in cases:
        suite.append(_testcase(result))
    return suite


def junit_document(record: RunRecord) -> etree._Element:
    """Build the `<testsuites>` element of a run."""
    started = record.started
    sections: dict[str, list[CaseResult]] = {}
    for result in record.results():
        sections.setdefault(result.info.section, []).append(result)
    title = f"OpenAIR conformance: {started.target}" if started else "OpenAIR conformance"
    root = etree.Element("testsuites", name=_text(title))
    for index, section in enumerate(sorted(sections, key=section_key)):
        root.append(_suite(index, section, sections[section], started))
    for attribute in ("tests", "failures", "errors"):
        total = sum(int(suite.get(attribute, "0")) for suite in root)
        root.set(attribute, str(total))
    root.set("time", f"{record.effective_summary().duration:.3f}")
    return root


class JUnitReporter(FileReporter):
    """Write the run as JUnit XML to `path` when closed."""

    what = "JUnit report"

    def render(self) -> bytes:
        """Return the file's bytes for the recorded run."""
        return bytes(
            etree.tostring(
                junit_document(self.record),
                xml_declaration=True,
                encoding="UTF-8",
                pretty_print=True,
            )
        )
