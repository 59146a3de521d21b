"""The HTML report and the comparison page: structure, counts, escaping, differences."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import lxml.html
import pytest
from click.testing import CliRunner
from reporters_support import FAILING_ID, HOSTILE_TEXT, SYNTHETIC, Artifacts

from openair_conformance.cli import conform
from openair_conformance.model import (
    CaseFinished,
    RunFinished,
    RunStarted,
    RunSummary,
    TargetDeath,
    TraceEntry,
    Verdict,
)
from openair_conformance.reporters._common import DETAILED, RunRecord, by_section, format_time
from openair_conformance.reporters.html import HtmlReporter, render_report, write_comparison
from openair_conformance.reporters.jsonreport import ReportError


def _page(path: Path) -> Any:
    return lxml.html.fromstring(path.read_bytes())


def test_the_page_is_self_contained(artifacts: Artifacts) -> None:
    page = _page(artifacts.html)
    assert page.xpath("//link") == [] and page.xpath("//*[@src]") == []
    hrefs = page.xpath("//@href")
    assert hrefs and all(h.startswith("#") for h in hrefs)
    assert "default-src 'none'" in page.xpath("//meta[@http-equiv]/@content")[0]
    assert len(page.xpath("//style")) == 1


def test_the_run_section_names_target_server_date_and_options(artifacts: Artifacts) -> None:
    section = _page(artifacts.html).xpath("//section[@id='run']")[0]
    rows = {
        tr.xpath("th")[0].text_content(): tr.xpath("td")[0].text_content()
        for tr in section.xpath(".//tr")
    }
    started = artifacts.events[0]
    assert isinstance(started, RunStarted)
    assert rows["target"] == started.target and rows["server"] == "fake/0"
    assert rows["extensions"] == "pipelining" and rows["jobs"] == "3"
    assert rows["started"] == format_time(started.started)
    assert rows["expectations"] == started.options["expectations"]


def test_one_row_per_case_with_its_verdict(artifacts: Artifacts) -> None:
    rows = _page(artifacts.html).xpath("//table[@id='case-table']/tbody/tr")
    assert len(rows) == len(SYNTHETIC)
    verdicts = {r.info.id: r.verdict.value for r in artifacts.summary.results}
    assert {row.xpath("td[1]")[0].text_content(): row.get("data-verdict") for row in rows} == (
        verdicts
    )


def test_the_matrix_counts_match_the_results(artifacts: Artifacts) -> None:
    matrix = _page(artifacts.html).xpath("//table[contains(@class, 'matrix')]")[0]
    rows = matrix.xpath("tbody/tr")
    expected = by_section(artifacts.summary.results)
    assert [row.get("data-section") for row in rows] == list(expected)
    for row in rows:
        cells = [int(td.text_content()) for td in row.xpath("td")]
        counts = expected[row.get("data-section")]
        assert cells == [counts.get(v, 0) for v in Verdict] + [sum(counts.values())]
    link = matrix.xpath(".//a[@data-filter-verdict='fail']")[0]
    assert (link.get("data-filter-section"), link.text_content()) == ("6.7", "1")
    totals = [int(td.text_content()) for td in matrix.xpath("tfoot/tr/td")]
    assert totals == [artifacts.summary.count(v) for v in Verdict] + [len(SYNTHETIC)]


def test_each_case_has_a_detail_section_with_the_evidence(artifacts: Artifacts) -> None:
    page = _page(artifacts.html)
    for case in SYNTHETIC:
        assert len(page.xpath(f"//article[@id='case-{case.info.id}']")) == 1
    article = page.xpath(f"//article[@id='case-{FAILING_ID}']")[0]
    text = article.text_content()
    assert "A PING MUST be answered PING_SUCCESS" in text
    assert f"behaviour allowed for {FAILING_ID}" in text
    assert "PING was answered with a hostile frame" in text
    assert f"--case {FAILING_ID}" in text
    entries = article.xpath(".//ol[@class='trace']/li")
    result = next(r for r in artifacts.summary.results if r.info.id == FAILING_ID)
    assert len(entries) == len(result.trace)  # the full trace, not an excerpt
    opened = article.xpath(".//ol[@class='trace']/li/details[@open]/..")
    assert [li.get("id") for li in opened] == [f"case-{FAILING_ID}-t{result.divergence}"]
    directions = {li.get("class").split()[0] for li in entries}
    assert directions == {"d-in", "d-out", "d-note"}
    ids = page.xpath("//@id")
    assert len(ids) == len(set(ids))


def test_a_hostile_frame_stays_text(artifacts: Artifacts) -> None:
    source = artifacts.html.read_text(encoding="utf-8")
    assert "<script>alert" not in source and "<i>title</i>" not in source
    assert "\x1b" not in source and "\x00" not in source
    page = _page(artifacts.html)
    scripts = page.xpath("//script")
    assert len(scripts) == 1 and "alert" not in scripts[0].text_content()
    assert page.xpath("//b") == [] and page.xpath("//i") == []
    shown = [pre.text_content() for pre in page.xpath(f"//article[@id='case-{FAILING_ID}']//pre")]
    neutralised = HOSTILE_TEXT.replace("\x1b", "\\x1b").replace("\x00", "\\x00")
    assert neutralised in shown


def _variant(artifacts: Artifacts, tmp_path: Path, name: str, change: Any) -> Path:
    data = json.loads(artifacts.json.read_text(encoding="utf-8"))
    change(data)
    path = tmp_path / name
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def _flip(data: dict[str, Any]) -> None:
    data["server"]["server"] = "other/1"
    result = next(r for r in data["results"] if r["id"] == "SYN-001")
    result["verdict"] = "fail"
    result["message"] = "<b>broke</b>"
    data["summary"]["counts"]["pass"] -= 1
    data["summary"]["counts"]["fail"] += 1


def test_the_comparison_highlights_the_difference(artifacts: Artifacts, tmp_path: Path) -> None:
    other = _variant(artifacts, tmp_path, "other.json", _flip)
    output = tmp_path / "cmp" / "compare.html"
    write_comparison([artifacts.json, other], output)
    page = _page(output)
    head = [th.text_content() for th in page.xpath("//table[@id='compare-table']/thead/tr/th")]
    assert head == ["ID", "section", "title", "fake/0", "other/1"]
    rows = {
        tr.xpath("td[1]")[0].text_content(): tr
        for tr in page.xpath("//table[@id='compare-table']/tbody/tr")
    }
    assert set(rows) == {case.info.id for case in SYNTHETIC}
    differing = [cid for cid, tr in rows.items() if "differs" in tr.get("class")]
    assert differing == ["SYN-001"]
    cells = rows["SYN-001"].xpath("td")[3:]
    assert [c.text_content() for c in cells] == ["pass", "fail"]
    assert ["delta" in c.get("class") for c in cells] == [False, True]
    assert cells[1].get("title") == "<b>broke</b>"  # as text in an attribute, not markup
    assert page.xpath("//b") == []


def test_a_case_missing_from_one_report_differs(artifacts: Artifacts, tmp_path: Path) -> None:
    def drop(data: dict[str, Any]) -> None:
        data["results"] = [r for r in data["results"] if r["id"] != "SYN-003"]

    other = _variant(artifacts, tmp_path, "other.json", drop)
    output = tmp_path / "compare.html"
    write_comparison([artifacts.json, other, artifacts.json], output)
    page = _page(output)
    head = [th.text_content() for th in page.xpath("//table[@id='compare-table']/thead/tr/th")]
    assert head[3:] == ["fake/0 #1", "fake/0 #2", "fake/0 #3"]
    differing = page.xpath("//table[@id='compare-table']/tbody/tr[contains(@class, 'differs')]")
    assert [tr.xpath("td[1]")[0].text_content() for tr in differing] == ["SYN-003"]
    assert differing[0].xpath("td")[4].text_content() == "—"


def test_the_comparison_refuses_a_bad_report(artifacts: Artifacts, tmp_path: Path) -> None:
    def break_title(data: dict[str, Any]) -> None:
        data["results"][0]["title"] = "two\nlines"  # schema-valid, but not a valid case

    bad = _variant(artifacts, tmp_path, "bad.json", break_title)
    with pytest.raises(ReportError, match=r"bad\.json"):
        write_comparison([artifacts.json, bad], tmp_path / "out.html")
    with pytest.raises(ReportError):
        write_comparison([], tmp_path / "out.html")
    assert not (tmp_path / "out.html").exists()


def test_conform_report_writes_the_comparison(artifacts: Artifacts, tmp_path: Path) -> None:
    output = tmp_path / "page.html"
    result = CliRunner().invoke(conform, ["report", str(artifacts.json), "-o", str(output)])
    assert result.exit_code == 0, result.output
    rows = _page(output).xpath("//table[@id='compare-table']/tbody/tr")
    assert len(rows) == len(SYNTHETIC)


def _all_pass_record(artifacts: Artifacts, cases: int, entries: int) -> RunRecord:
    """A finished run of `cases` passing results, each with a trace of `entries` 500-byte frames."""
    model = next(r for r in artifacts.summary.results if r.info.id == FAILING_ID)
    trace = tuple(
        TraceEntry(t=i / 100, conn="primary", direction="in", tag="Message", text="x" * 500)
        for i in range(entries)
    )
    results = tuple(
        dataclasses.replace(
            model,
            info=dataclasses.replace(model.info, id=f"ALL-{n:03d}"),
            verdict=Verdict.PASS,
            message="",
            trace=trace,
            divergence=None,
        )
        for n in range(cases)
    )
    started = artifacts.events[0]
    assert isinstance(started, RunStarted)
    record = RunRecord()
    record.handle(dataclasses.replace(started, cases=cases))
    for result in results:
        record.handle(CaseFinished(result=result))
    summary = RunSummary(counts=((Verdict.PASS, cases),), duration=1.0, results=results)
    record.handle(RunFinished(summary=summary))
    return record


def test_an_all_pass_report_stays_small(artifacts: Artifacts) -> None:
    record = _all_pass_record(artifacts, cases=200, entries=40)  # 20 kB of trace per case
    small = render_report(record, traces="failing").encode()
    assert len(small) < 2048 * 200, len(small)  # under 2 kB per case, page frame included
    full = render_report(record, traces="all").encode()
    assert len(full) > 200 * 40 * 500  # the traces are what was left out
    page = lxml.html.fromstring(small)
    assert len(page.xpath("//article[contains(@class, 'case')]")) == 200
    assert page.xpath("//ol[@class='trace']") == []
    assert (
        "trace of 40 entries not included"
        in page.xpath("//article[@id='case-ALL-007']")[0].text_content()
    )


def test_the_page_opens_on_the_matrix(artifacts: Artifacts) -> None:
    page = _page(artifacts.html)
    sections = [s.get("id") for s in page.xpath("//body/section")]
    assert sections[0] == "matrix" and sections.index("matrix") < sections.index("details")
    children = [el for el in page.xpath("//body")[0] if el.tag != "script"]
    assert [el.tag for el in children[:2]] == ["header", "section"]  # only the title line
    assert children[1].get("id") == "matrix"
    assert page.xpath("//header//table") == []


def test_only_results_that_are_not_passes_carry_their_trace(artifacts: Artifacts) -> None:
    page = _page(artifacts.html)
    traced = {a.get("id") for a in page.xpath("//article[.//ol[@class='trace']]")}
    expected = {f"case-{r.info.id}" for r in artifacts.summary.results if r.verdict in DETAILED}
    assert traced == expected and "case-SYN-001" not in traced
    record = RunRecord()
    for event in artifacts.events:
        record.handle(event)
    every = lxml.html.fromstring(render_report(record, traces="all"))
    assert every.xpath("//p[@class='omitted']") == []
    assert len(page.xpath("//p[@class='omitted']")) == len(SYNTHETIC) - len(expected)
    assert len(every.xpath("//article[.//ol[@class='trace']]")) > len(traced)
    with pytest.raises(ValueError, match="traces"):
        HtmlReporter(Path("x.html"), traces="some")


def test_a_target_death_and_a_rerun_are_shown(artifacts: Artifacts) -> None:
    record = RunRecord()
    for event in artifacts.events:
        if isinstance(event, CaseFinished) and event.result.info.id == "SYN-003":
            died = dataclasses.replace(event.result, target_died=True, rerun_after_restart=True)
            event = CaseFinished(result=died)
        elif isinstance(event, RunFinished):
            death = TargetDeath(case="SYN-003", detail="no PING answer", action="restarted")
            summary = dataclasses.replace(
                record.effective_summary(), target_deaths=(death,), not_run=("SYN-099",)
            )
            event = RunFinished(summary=summary)
        record.handle(event)
    page = lxml.html.fromstring(render_report(record))
    banners = [p.text_content() for p in page.xpath("//header/p[@class='banner']")]
    assert banners == [
        "The target died during case SYN-003: no PING answer; restarted.",
        "Not run after that: SYN-099.",
    ]
    article = page.xpath("//article[@id='case-SYN-003']")[0]
    assert "rerun after a restart" in article.text_content()
    assert "The target died during this case." in article.text_content()
