"""The console reporter: progress while the suite runs, then the summary and what failed, and why.

On a terminal (and without `verbose`) a single progress line is redrawn in place and every
result that is not a plain pass is printed above it; otherwise each result is one line, and with
`verbose` its message and whole trace follow. At the end: counts by spec section, the totals,
the measured latencies, vacuous passes, expectations that match no case, and for each problem
(`_common.DETAILED`) the requirement sentences, what was allowed, what happened, the trace up to
the divergence and the command that repeats the case. Colour only on a terminal, and never when
NO_COLOR is set (https://no-color.org). Everything from the server passes through `safe_text`,
so a hostile frame cannot drive the terminal.
"""

from __future__ import annotations

import os
import shutil
import textwrap
from collections.abc import Iterable
from typing import TextIO

from openair_conformance.model import (
    CaseFinished,
    CaseResult,
    CaseStarted,
    Event,
    RunFinished,
    RunStarted,
    RunSummary,
    TraceEntry,
    Verdict,
)
from openair_conformance.registry import requirement_sentences
from openair_conformance.reporters._common import (
    DETAILED,
    VERDICT_LEGEND,
    RunRecord,
    by_section,
    entry_head,
    excerpt,
    safe_text,
    section_label,
)

__all__ = ["ConsoleReporter", "Style"]

_COLOURS = {
    Verdict.PASS: "32",
    Verdict.PASS_NONSTRICT: "33",
    Verdict.INFORMATIONAL: "34",
    Verdict.NOT_APPLICABLE: "2",
    Verdict.EXPECTED_FAILURE: "36",
    Verdict.UNEXPECTED_PASS: "1;31",
    Verdict.FAIL: "1;31",
    Verdict.TIMING: "33",
    Verdict.INCONCLUSIVE: "35",
    Verdict.ERROR: "1;35",
}
_ENTRY_CHARS = 600  # of one trace entry in a failure's excerpt
_ENTRY_LINES = 12
_VERBOSE_ENTRY_CHARS = 4000
_WIDTH = 100


class Style:
    """ANSI styling, or none."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled

    def paint(self, code: str, text: str) -> str:
        """Wrap `text` in the SGR `code` when styling is on."""
        return f"\x1b[{code}m{text}\x1b[0m" if self.enabled and text else text

    def verdict(self, verdict: Verdict, text: str | None = None) -> str:
        """`text` (default: the verdict's name) in the verdict's colour."""
        return self.paint(_COLOURS[verdict], verdict.value if text is None else text)

    def bold(self, text: str) -> str:
        return self.paint("1", text)

    def dim(self, text: str) -> str:
        return self.paint("2", text)


def _isatty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _no_color() -> bool:
    return bool(os.environ.get("NO_COLOR"))


def _indent(text: str, prefix: str = "    ") -> list[str]:
    return [prefix + line for line in (text.splitlines() or [""])]


def _cut(text: str, chars: int, lines: int | None = None) -> str:
    """Cut `text` to `chars` characters and `lines` lines, saying how much was left out."""
    out = text[:chars]
    parts = out.splitlines()
    if lines is not None and len(parts) > lines:
        out = "\n".join(parts[:lines])
    if len(out) < len(text):
        out += f" … ({len(text) - len(out)} more characters)"
    return out


class ConsoleReporter:
    """Report a run on a text stream (stdout); see the module docstring."""

    def __init__(
        self,
        stream: TextIO,
        verbose: bool = False,
        *,
        color: bool | None = None,
        live: bool | None = None,
        width: int | None = None,
    ) -> None:
        tty = _isatty(stream)
        self.stream = stream
        self.verbose = verbose
        self.live = (tty and not verbose) if live is None else live
        self.style = Style((tty and not _no_color()) if color is None else color)
        self.width = width
        self.record = RunRecord()
        self._progress_shown = False
        self._closed = False

    # -- output ---------------------------------------------------------------------------------

    def _columns(self) -> int:
        return self.width or shutil.get_terminal_size((_WIDTH, 24)).columns

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
        except UnicodeEncodeError:  # a terminal that cannot show arrows or the server's text
            encoding = getattr(self.stream, "encoding", None) or "ascii"
            self.stream.write(text.encode(encoding, "backslashreplace").decode(encoding))

    def _lines(self, lines: Iterable[str]) -> None:
        self._clear_progress()
        self._write("".join(line + "\n" for line in lines))

    def _clear_progress(self) -> None:
        if self._progress_shown:
            self._write("\r\x1b[K")
            self._progress_shown = False

    def _draw_progress(self) -> None:
        started = self.record.started
        if not self.live or started is None:
            return
        done, total = len(self.record.finished), max(started.cases, 1)
        bar_width = 20
        filled = bar_width * done // total
        bar = "█" * filled + "░" * (bar_width - filled)
        problems = sum(1 for r in self.record.finished.values() if r.verdict in DETAILED)
        running = ", ".join(sorted(self.record.running)[:3])
        more = "…" if len(self.record.running) > 3 else ""
        text = f"[{done:>{len(str(total))}}/{total}] {bar} {100 * done // total:3d}%"
        text += f"  problems {problems}" + (f"  running {running}{more}" if running else "")
        text = text[: max(10, self._columns() - 1)]
        self._write("\r" + text + "\x1b[K")
        self.stream.flush()
        self._progress_shown = True

    # -- events ---------------------------------------------------------------------------------

    def handle(self, event: Event) -> None:
        """Show one event."""
        self.record.handle(event)
        if isinstance(event, RunStarted):
            self._lines(self._header(event))
        elif isinstance(event, CaseFinished):
            self._finished(event.result)
        elif isinstance(event, RunFinished):
            self._lines(self._summary(event.summary))
        if isinstance(event, (RunStarted, CaseStarted, CaseFinished)):
            self._draw_progress()

    def close(self) -> None:
        """End the output (once): clear the progress line; summarise a run that stopped early."""
        if self._closed:
            return
        self._closed = True
        if self.record.started is not None and not self.record.complete:
            summary = self.record.effective_summary()
            lines = [self.style.bold("The run stopped before every case was judged.")]
            self._lines([*lines, *self._summary(summary)])
        self._clear_progress()
        self.stream.flush()

    def _header(self, event: RunStarted) -> list[str]:
        server = event.server
        name = safe_text(server.server or "unnamed server")
        proto = f" ({safe_text(server.protocol)})" if server.protocol else ""
        legacy = " — legacy server, core only" if server.legacy else ""
        exts = ", ".join(safe_text(ext) for ext in server.capabilities) or "none"
        opts = event.options
        return [
            self.style.bold(f"OpenAIR conformance: {safe_text(event.target)}"),
            f"server {name}{proto}{legacy}; extensions: {exts}",
            f"{event.cases} case(s), jobs {opts.get('jobs', '1')}, rtt {server.rtt_ms:.2f} ms, "
            f"deadline {opts.get('deadline_s', '?')} s (scale {opts.get('timeout_scale', '1')})",
            "",
        ]

    def _finished(self, result: CaseResult) -> None:
        if self.live and result.verdict is Verdict.PASS:
            return
        lines = [self._result_line(result)]
        if self.verbose:
            lines += self._verbose_body(result)
        self._lines(lines)

    def _result_line(self, result: CaseResult) -> str:
        verdict = self.style.verdict(result.verdict, f"{result.verdict.value:<16}")
        title = safe_text(result.info.title)
        return f"{verdict} {result.info.id:<10} {title} ({result.duration:.2f} s)"

    def _verbose_body(self, result: CaseResult) -> list[str]:
        lines = _indent(safe_text(result.message)) if result.message else []
        for index, entry in enumerate(result.trace):
            lines += self._entry(index, entry, _VERBOSE_ENTRY_CHARS, None, marked=False)
        return lines

    # -- the summary ----------------------------------------------------------------------------

    def _summary(self, summary: RunSummary) -> list[str]:
        lines = ["", self.style.bold("Results by spec section")]
        for section, counts in by_section(summary.results).items():
            label = safe_text(section_label(section))
            label = label if len(label) <= 44 else label[:43] + "…"
            lines.append(f"  {label:<44} {self._counts(counts.items())}")
        lines += ["", self._latencies(summary), *self._vacuous(summary), *self._unknown(summary)]
        problems = [r for r in summary.results if r.verdict in DETAILED]
        if problems:
            lines += ["", self.style.bold(f"Problems ({len(problems)})")]
            lines += [f"  {text}" for text in VERDICT_LEGEND]
            for result in sorted(problems, key=lambda r: DETAILED.index(r.verdict)):
                lines += ["", *self._details(result)]
        return [*lines, *self._deaths(summary), "", self.style.bold(self._totals(summary))]

    def _deaths(self, summary: RunSummary) -> list[str]:
        """Say when the target died, during which case, and what the run did then."""
        lines: list[str] = []
        for death in summary.target_deaths:
            others = f" (also running: {', '.join(death.in_flight)})" if death.in_flight else ""
            lines.append(
                self.style.bold(f"The target died during {death.case}{others}: {death.action}")
                + f" — {safe_text(death.detail)}"
            )
        reruns = sorted(r.info.id for r in summary.results if r.rerun_after_restart)
        if reruns:
            lines.append(f"rerun after restart: {', '.join(reruns)}")
        if summary.not_run:
            lines.append(f"not run ({len(summary.not_run)}): {', '.join(summary.not_run)}")
        return ["", *lines] if lines else []

    def _counts(self, counts: Iterable[tuple[Verdict, int]]) -> str:
        ordered = sorted(counts, key=lambda vc: list(Verdict).index(vc[0]))
        return " · ".join(self.style.verdict(v, f"{v.value} {n}") for v, n in ordered if n)

    def _totals(self, summary: RunSummary) -> str:
        counts = self._counts(summary.counts) or "no results"
        return f"{summary.total} case(s) in {summary.duration:.1f} s: {counts}"

    def _latencies(self, summary: RunSummary) -> str:
        values = dict(summary.latencies)
        text = f"latency: rtt {values.get('rtt_ms', 0.0):.2f} ms"
        if "post_to_wakeup_p50_ms" in values:
            samples = int(values.get("post_to_wakeup_samples", 0))
            text += (
                f" · post→wakeup p50 {values['post_to_wakeup_p50_ms']:.2f} ms, "
                f"p99 {values.get('post_to_wakeup_p99_ms', 0.0):.2f} ms ({samples} samples)"
            )
        else:
            text += " · post→wakeup: no samples"
        known = {"rtt_ms", "post_to_wakeup_p50_ms", "post_to_wakeup_p99_ms"}
        known.add("post_to_wakeup_samples")
        others = [f"{safe_text(k)} {v:g}" for k, v in summary.latencies if k not in known]
        return text + (" · " + ", ".join(others) if others else "")

    def _vacuous(self, summary: RunSummary) -> list[str]:
        if not summary.vacuous:
            return []
        results = {r.info.id: r for r in summary.results}
        count = len(summary.vacuous)
        lines = [f"vacuous ({count}): would pass but proves nothing, so inconclusive (OA-GEN-7)"]
        for case_id in summary.vacuous:
            reason = results[case_id].message if case_id in results else ""
            lines.append(f"  {safe_text(case_id)}  {safe_text(reason)}")
        return lines

    def _unknown(self, summary: RunSummary) -> list[str]:
        if not summary.unknown_expectations:
            return []
        count = len(summary.unknown_expectations)
        lines = [self.style.paint("33", f"expectations that match no case ({count}):")]
        return lines + [f"  {safe_text(entry)}" for entry in summary.unknown_expectations]

    # -- one problem ----------------------------------------------------------------------------

    def _details(self, result: CaseResult) -> list[str]:
        info = result.info
        lines = [
            f"{self.style.verdict(result.verdict, result.verdict.value.upper())}  "
            f"{self.style.bold(info.id)}  {safe_text(info.title)}",
            f"  section {safe_text(section_label(info.section))} · level {info.level.value} · "
            f"{result.duration:.2f} s",
            "  requirements:",
        ]
        for req_id, level, sentence in requirement_sentences(info):
            pad = " " * 6
            wrapped = textwrap.fill(
                safe_text(sentence), width=_WIDTH, initial_indent=pad, subsequent_indent=pad
            )
            lines += [f"    {req_id} ({level}):", wrapped]
        if result.expected:
            lines += ["  allowed / expected:", *_indent(safe_text(result.expected))]
        lines += ["  what happened:", *_indent(safe_text(result.message or "(no message)"))]
        if result.expectation_reason:
            lines.append(f"  expectation: {safe_text(result.expectation_reason)}")
        lines += self._excerpt(result)
        lines.append(f"  repro: {self.style.bold(safe_text(result.repro))}")
        return lines

    def _excerpt(self, result: CaseResult) -> list[str]:
        start, entries = excerpt(result)
        if not entries:
            return ["  trace: (empty)"]
        end = start + len(entries) - 1
        where = "the divergence" if result.divergence is not None else "the end"
        lines = [f"  trace #{start}–#{end} of {len(result.trace)} (up to {where}):"]
        for offset, entry in enumerate(entries):
            index = start + offset
            marked = index == result.divergence
            lines += self._entry(index, entry, _ENTRY_CHARS, _ENTRY_LINES, marked=marked)
        return lines

    def _entry(
        self, index: int, entry: TraceEntry, chars: int, lines: int | None, *, marked: bool
    ) -> list[str]:
        head = ("  ▶ " if marked else "    ") + entry_head(index, entry)
        head = self.style.paint("1;31", head) if marked else self.style.dim(head)
        return [head, *_indent(safe_text(_cut(entry.text, chars, lines)), "        ")]
