"""What the reporters share: the run record, display-safe text, sections, trace excerpts, files.

Trace text is hostile: a server under test may send any bytes, and the trace keeps them as they
travelled (decoded as UTF-8). `safe_text` makes such text safe to show on a terminal and to put
into XML or HTML (both reject most control characters); the JSON report alone keeps it exact.
"""

from __future__ import annotations

import datetime
import os
import re
import secrets
import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from openair_conformance.model import (
    CaseFinished,
    CaseInfo,
    CaseResult,
    CaseStarted,
    Event,
    RunFinished,
    RunStarted,
    RunSummary,
    TraceEntry,
    Verdict,
)

__all__ = [
    "DETAILED",
    "EXCERPT_ENTRIES",
    "VERDICT_LEGEND",
    "RunRecord",
    "by_section",
    "direction_arrow",
    "entry_head",
    "excerpt",
    "first_line",
    "format_time",
    "safe_text",
    "section_key",
    "section_label",
    "section_titles",
    "write_atomic",
    "write_failed",
]

#: Verdicts whose details (requirements, expectation, message, trace excerpt) every report shows.
DETAILED = (
    Verdict.FAIL,
    Verdict.ERROR,
    Verdict.TIMING,
    Verdict.UNEXPECTED_PASS,
    Verdict.INCONCLUSIVE,
    Verdict.PASS_NONSTRICT,
)
#: What the verdicts that are not plain pass or fail mean (README, "Verdicts"; spec 1.2).
VERDICT_LEGEND = (
    "timing: late past the deadline (max(1 s, 10 x RTT)) but within the fail threshold "
    "(2 deadlines); later is fail (OA-GEN-6)",
    "inconclusive: the suite could not decide, or what the case checks never happened "
    "(a vacuous pass, OA-GEN-7)",
)
#: How many trace entries an excerpt shows, up to and including the divergence.
EXCERPT_ENTRIES = 10

# C0 and C1 controls (tab and newline excepted), lone surrogates, the two non-characters XML
# forbids, and the bidi overrides that can make a terminal or a page show other text than is there.
_UNSAFE_RE = re.compile(
    "[\x00-\x08\x0b-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff\u202a-\u202e\u2066-\u2069]"
)
_HEADING_RE = re.compile(r"^#{2,4}\s+([0-9]+(?:\.[0-9]+)*)\.?\s+(.+?)\s*$")
_ARROWS = {"out": "→", "in": "←", "note": "·"}


def _escape_char(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code <= 0xFF else f"\\u{code:04x}"


def safe_text(text: str) -> str:
    """Return `text` with control characters, surrogates and bidi overrides as `\\xNN`/`\\uNNNN`."""
    return _UNSAFE_RE.sub(_escape_char, text)


def first_line(text: str, limit: int = 200) -> str:
    """Return the first non-empty line of `text`, cut after `limit` characters."""
    line = next((part.strip() for part in text.splitlines() if part.strip()), "")
    return line if len(line) <= limit else line[: limit - 1] + "…"


def section_key(section: str) -> tuple[int, ...]:
    """Sort key of a spec section ("6.10" after "6.9")."""
    return tuple(int(part) for part in section.split(".") if part.isdigit())


@cache
def section_titles() -> dict[str, str]:
    """Return the numbered headings of the spec, section number → title (empty if unreadable)."""
    try:
        from openair.catalogue import DEFAULT_SPEC

        lines = Path(DEFAULT_SPEC).read_text(encoding="utf-8").splitlines()
    except (ImportError, OSError, UnicodeDecodeError):
        return {}
    titles: dict[str, str] = {}
    for line in lines:
        match = _HEADING_RE.match(line)
        if match:
            titles.setdefault(match.group(1), match.group(2).replace("`", ""))
    return titles


def section_label(section: str) -> str:
    """Return "6.7 PING, KEEPALIVE and STATUS" (the bare number if the spec has no title)."""
    title = section_titles().get(section, "")
    return f"{section} {title}" if title else section


def by_section(results: Iterable[CaseResult]) -> dict[str, dict[Verdict, int]]:
    """Count verdicts per spec section, sections in spec order."""
    table: dict[str, dict[Verdict, int]] = {}
    for result in results:
        row = table.setdefault(result.info.section, {})
        row[result.verdict] = row.get(result.verdict, 0) + 1
    return {key: table[key] for key in sorted(table, key=section_key)}


def excerpt(result: CaseResult, size: int = EXCERPT_ENTRIES) -> tuple[int, tuple[TraceEntry, ...]]:
    """Return (index of the first entry, entries): the last `size` entries up to the divergence.

    Without a divergence (or with one outside the trace) the excerpt is the end of the trace.
    """
    trace = result.trace
    end = len(trace)
    if result.divergence is not None and 0 <= result.divergence < len(trace):
        end = result.divergence + 1
    start = max(0, end - size)
    return start, trace[start:end]


def direction_arrow(direction: str) -> str:
    """→ for a frame sent by the suite, ← for one received, · for a note."""
    return _ARROWS.get(direction, "?")


def entry_head(index: int, entry: TraceEntry) -> str:
    """Return the one-line header of a trace entry: `#3 +0.012 s → primary Message`."""
    words = [f"#{index}", f"+{entry.t:.3f} s", direction_arrow(entry.direction)]
    words += [safe_text(word) for word in (entry.conn, entry.tag) if word]
    return " ".join(words)


def format_time(epoch: float) -> str:
    """Return an epoch time as `2026-11-22T17:40:12Z` (UTC, seconds)."""
    moment = datetime.datetime.fromtimestamp(epoch, tz=datetime.UTC)
    return moment.strftime("%Y-%m-%dT%H:%M:%SZ")


def write_atomic(path: Path, data: bytes, what: str = "report") -> None:
    """Write `data` to `path` through a temporary file, so a reader never sees half a report.

    Missing parent folders are created, and that is said on stderr (a mistyped folder should
    not go unnoticed). The file gets the usual permissions (the umask's).
    """
    path = Path(path)
    if not path.parent.is_dir():
        path.parent.mkdir(parents=True, exist_ok=True)
        print(f"note: created the folder {path.parent} for the {what}", file=sys.stderr)
    temp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        with temp.open("xb") as out:
            out.write(data)
        os.replace(temp, path)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise


def write_failed(what: str, path: Path, exc: Exception) -> None:
    """Say on stderr that a report could not be written.

    `close()` must not raise: the engine closes reporters one after the other, and one failing
    report must not cost the others.
    """
    print(f"error: could not write the {what} to {path}: {exc}", file=sys.stderr)


@dataclass(slots=True)
class RunRecord:
    """The events of one run, gathered; complete once `RunFinished` came."""

    started: RunStarted | None = None
    summary: RunSummary | None = None
    finished: dict[str, CaseResult] = field(default_factory=dict)
    running: dict[str, CaseInfo] = field(default_factory=dict)

    def handle(self, event: Event) -> None:
        """Record one event."""
        if isinstance(event, RunStarted):
            self.started = event
        elif isinstance(event, CaseStarted):
            self.running[event.info.id] = event.info
        elif isinstance(event, CaseFinished):
            self.running.pop(event.result.info.id, None)
            self.finished[event.result.info.id] = event.result
        elif isinstance(event, RunFinished):
            self.summary = event.summary

    @property
    def complete(self) -> bool:
        """Whether the run finished (RunFinished came)."""
        return self.summary is not None

    def results(self) -> tuple[CaseResult, ...]:
        """Every result, in case-ID order (the summary's, once the run finished)."""
        if self.summary is not None and self.summary.results:
            return self.summary.results
        return tuple(self.finished[key] for key in sorted(self.finished))

    def effective_summary(self) -> RunSummary:
        """The run's summary; for a run that stopped early, one counted from the results so far."""
        if self.summary is not None:
            return self.summary
        results = self.results()
        counts = {v: sum(1 for r in results if r.verdict is v) for v in Verdict}
        rtt = self.started.server.rtt_ms if self.started is not None else 0.0
        return RunSummary(
            counts=tuple((v, n) for v, n in counts.items() if n),
            duration=time.time() - self.started.started if self.started is not None else 0.0,
            latencies=(("rtt_ms", rtt),),
            results=results,
        )


class FileReporter:
    """A reporter that records the events and writes one file when closed.

    Subclasses give `what` (for error messages) and `render()`; the file is written once,
    atomically, and only if a run started; a write error is reported on stderr, not raised,
    and leaves `failed` true (the CLI exits 4 then).
    """

    what = "report"

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        self.record = RunRecord()
        self.written = False
        self.failed = False
        self._closed = False

    def handle(self, event: Event) -> None:
        """Record one event."""
        self.record.handle(event)

    def render(self) -> bytes:
        """Return the file's bytes for the recorded run."""
        raise NotImplementedError

    def close(self) -> None:
        """Write the file (once), if a run started; a write error is reported on stderr."""
        if self._closed:
            return
        self._closed = True
        if self.record.started is None:
            return
        try:
            write_atomic(self.path, self.render(), self.what)
        except OSError as exc:
            write_failed(self.what, self.path, exc)
            self.failed = True
            return
        self.written = True
