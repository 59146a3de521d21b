"""The JSON report: the whole run — options, server, summary, every result with its full trace.

The format is `openair-conformance-report/1`, described by `schemas/report.schema.json`. Text is
kept exactly as recorded (the JSON escapes take care of control characters; a lone surrogate is
written as its `\\uXXXX` escape). Numbers that are not finite become null. The file is written
when the reporter is closed; nothing is written when no run started. `load_report` reads a report
back, checked against the schema; `decode_started`, `decode_summary` and `decode_result` turn it
into the model's values again (the comparison page and the tests use them).
"""

from __future__ import annotations

import json
import math
from functools import cache
from pathlib import Path
from typing import Any, NoReturn

import jsonschema  # type: ignore[import-untyped]  # no stubs in the test extra

from openair_conformance import __version__
from openair_conformance.model import (
    CaseInfo,
    CaseResult,
    Level,
    RunStarted,
    RunSummary,
    ServerInfo,
    TargetDeath,
    TraceEntry,
    Verdict,
)
from openair_conformance.registry import requirement_sentences
from openair_conformance.reporters._common import (
    FileReporter,
    RunRecord,
    by_section,
    format_time,
    section_titles,
)

__all__ = [
    "REPORT_FORMAT",
    "SCHEMA_PATH",
    "JsonReporter",
    "ReportError",
    "decode_result",
    "decode_started",
    "decode_summary",
    "load_report",
    "report_data",
    "report_schema",
    "schema_errors",
]

REPORT_FORMAT = "openair-conformance-report/1"
SCHEMA_PATH = Path(__file__).resolve().parent.parent / "schemas" / "report.schema.json"
MAX_REPORT_BYTES = 1 << 30  # a report larger than this is not one of ours


class ReportError(ValueError):
    """A JSON report cannot be read: unreadable, not JSON, or not of the schema."""


@cache
def report_schema() -> dict[str, Any]:
    """The JSON Schema of the report (schemas/report.schema.json)."""
    schema: dict[str, Any] = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
    return schema


def _number(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _measures(pairs: tuple[tuple[str, float], ...]) -> list[dict[str, Any]]:
    return [{"name": name, "value": _number(value)} for name, value in pairs]


def _counts(counts: dict[Verdict, int]) -> dict[str, int]:
    return {v.value: counts.get(v, 0) for v in Verdict}


def _server(server: ServerInfo) -> dict[str, Any]:
    return {
        "legacy": server.legacy,
        "server": server.server,
        "protocol": server.protocol,
        "capabilities": list(server.capabilities),
        "limits": [{"name": name, "value": value} for name, value in server.limits],
        "rtt_ms": _number(server.rtt_ms),
    }


def _summary(summary: RunSummary, unfinished: list[str]) -> dict[str, Any]:
    titles = section_titles()
    return {
        "total": summary.total,
        "duration_s": _number(summary.duration),
        "counts": _counts(dict(summary.counts)),
        "latencies": _measures(summary.latencies),
        "vacuous": list(summary.vacuous),
        "unknown_expectations": list(summary.unknown_expectations),
        "by_section": [
            {"section": section, "title": titles.get(section, ""), "counts": _counts(counts)}
            for section, counts in by_section(summary.results).items()
        ],
        "unfinished": unfinished,
        "target_deaths": [
            {"case": d.case, "detail": d.detail, "action": d.action, "in_flight": list(d.in_flight)}
            for d in summary.target_deaths
        ],
        "not_run": list(summary.not_run),
    }


def encode_result(result: CaseResult) -> dict[str, Any]:
    """Return one result as the report holds it."""
    info = result.info
    return {
        "id": info.id,
        "title": info.title,
        "section": info.section,
        "level": info.level.value,
        "requirements": [
            {"id": rid, "level": level, "text": text}
            for rid, level, text in requirement_sentences(info)
        ],
        "needs": sorted(info.needs),
        "serial": info.serial,
        "allowed": list(info.allowed),
        "verdict": result.verdict.value,
        "message": result.message,
        "expected": result.expected,
        "divergence": result.divergence,
        "duration_s": _number(result.duration),
        "repro": result.repro,
        "measurements": _measures(result.measurements),
        "expectation_reason": result.expectation_reason,
        "target_died": result.target_died,
        "rerun_after_restart": result.rerun_after_restart,
        "trace": [
            {"t": e.t, "conn": e.conn, "direction": e.direction, "tag": e.tag, "text": e.text}
            for e in result.trace
        ],
    }


def report_data(record: RunRecord) -> dict[str, Any]:
    """Return the report of a run that started (RunStarted came) as a JSON-ready dict."""
    started = record.started
    if started is None:
        raise ValueError("no run started: there is nothing to report")
    summary = record.effective_summary()
    return {
        "format": REPORT_FORMAT,
        "generator": {"name": "openair-conformance", "version": __version__},
        "complete": record.complete,
        "target": started.target,
        "started": started.started,
        "started_utc": format_time(started.started),
        "options": dict(started.options),
        "server": _server(started.server),
        "cases_selected": started.cases,
        "summary": _summary(summary, sorted(record.running)),
        "results": [encode_result(result) for result in summary.results],
    }


def dump_report(data: dict[str, Any]) -> bytes:
    """Serialise a report as UTF-8 JSON (lone surrogates as `\\uXXXX`, which JSON reads back)."""
    text = json.dumps(data, ensure_ascii=False, allow_nan=False, indent=1)
    # After json.dumps the only characters UTF-8 cannot encode are lone surrogates, and their
    # backslash escape is exactly JSON's escape for them.
    return (text + "\n").encode("utf-8", "backslashreplace")


class JsonReporter(FileReporter):
    """Write the run as a JSON report to `path` when closed."""

    what = "JSON report"

    def render(self) -> bytes:
        """Return the file's bytes for the recorded run."""
        return dump_report(report_data(self.record))


# -- reading a report back ---------------------------------------------------------------------


def _refuse_constant(name: str) -> NoReturn:
    raise ValueError(f"{name} is not JSON")


def load_report(path: Path | str) -> dict[str, Any]:
    """Read a JSON report and check it against the schema; ReportError says what is wrong."""
    path = Path(path)
    try:
        with path.open("rb") as source:
            raw = source.read(MAX_REPORT_BYTES + 1)
    except OSError as exc:
        raise ReportError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    if len(raw) > MAX_REPORT_BYTES:
        raise ReportError(f"{path}: larger than {MAX_REPORT_BYTES} bytes")
    try:
        data = json.loads(raw.decode("utf-8"), parse_constant=_refuse_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise ReportError(f"{path}: not a JSON document: {exc}") from exc
    if not isinstance(data, dict) or data.get("format") != REPORT_FORMAT:
        found = data.get("format") if isinstance(data, dict) else None
        raise ReportError(f"{path}: not an {REPORT_FORMAT} report (format {found!r})")
    problems = schema_errors(data)
    if problems:
        shown = "; ".join(problems[:5]) + (f"; … {len(problems) - 5} more" if problems[5:] else "")
        raise ReportError(f"{path}: does not follow the report schema: {shown}")
    return data


@cache
def _validator() -> Any:
    schema = report_schema()
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def schema_errors(data: Any) -> list[str]:
    """Return every violation of the report schema by `data` as "/json/pointer: what"."""
    found = sorted(_validator().iter_errors(data), key=lambda e: list(map(str, e.absolute_path)))
    return [f"/{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in found]


def _float(value: float | None) -> float:
    return math.nan if value is None else float(value)


def _pairs(items: list[dict[str, Any]]) -> tuple[tuple[str, float], ...]:
    return tuple((item["name"], _float(item["value"])) for item in items)


def decode_result(item: dict[str, Any]) -> CaseResult:
    """Turn one result of a (validated) report back into a CaseResult."""
    info = CaseInfo(
        id=item["id"],
        title=item["title"],
        section=item["section"],
        requirements=tuple(req["id"] for req in item["requirements"]),
        level=Level(item["level"]),
        needs=frozenset(item["needs"]),
        serial=item["serial"],
        allowed=tuple(item["allowed"]),
    )
    return CaseResult(
        info=info,
        verdict=Verdict(item["verdict"]),
        message=item["message"],
        expected=item["expected"],
        trace=tuple(TraceEntry(**entry) for entry in item["trace"]),
        divergence=item["divergence"],
        duration=_float(item["duration_s"]),
        repro=item["repro"],
        measurements=_pairs(item["measurements"]),
        expectation_reason=item["expectation_reason"],
        target_died=item.get("target_died", False),
        rerun_after_restart=item.get("rerun_after_restart", False),
    )


def decode_started(data: dict[str, Any]) -> RunStarted:
    """Rebuild the RunStarted event of a (validated) report."""
    server = data["server"]
    return RunStarted(
        target=data["target"],
        started=data["started"],
        options=dict(data["options"]),
        server=ServerInfo(
            legacy=server["legacy"],
            capabilities=tuple(server["capabilities"]),
            limits=tuple((lim["name"], lim["value"]) for lim in server["limits"]),
            rtt_ms=_float(server["rtt_ms"]),
            server=server["server"],
            protocol=server["protocol"],
        ),
        cases=data["cases_selected"],
    )


def decode_summary(data: dict[str, Any]) -> RunSummary:
    """Rebuild the RunSummary of a (validated) report, results included."""
    summary = data["summary"]
    counts = summary["counts"]
    return RunSummary(
        counts=tuple((v, counts[v.value]) for v in Verdict if counts[v.value]),
        duration=_float(summary["duration_s"]),
        latencies=_pairs(summary["latencies"]),
        vacuous=tuple(summary["vacuous"]),
        unknown_expectations=tuple(summary["unknown_expectations"]),
        results=tuple(decode_result(item) for item in data["results"]),
        target_deaths=tuple(
            TargetDeath(
                case=d["case"],
                detail=d["detail"],
                action=d["action"],
                in_flight=tuple(d["in_flight"]),
            )
            for d in summary.get("target_deaths", [])
        ),
        not_run=tuple(summary.get("not_run", [])),
    )
