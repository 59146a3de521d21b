"""The report: per module, what the suite did to the mutants, and every survivor explained.

`MutantRecord`s come from the cosmic-ray sessions (`record_from`) or, in tests, are made by
hand. Survivors (survived, not-executed) are explained in equivalent.toml under their stable
key with a one-line reason that starts `equivalent:` or `unobservable over TCP:`; explained
survivors leave the kill rate's denominator, the others are listed UNEXPLAINED. A survivor
that a rule of rules.py explains (IF_SURVIVES) is explained by the rule's argument; a mutant a
PRE_JUDGE rule explains is `by-rule` (not judged, outside the rate). Timeouts count as killed
(the mutant hung the server or the suite). When a module was judged by sample (some mutants
not run), its rate is an estimate and the report gives a 95 % Wilson interval for it.
"""

from __future__ import annotations

import json
import math
import statistics
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tools.mutation import group_of

__all__ = [
    "REASON_PREFIXES",
    "RULE_PREFIX",
    "STATUSES",
    "TARGET",
    "ModuleRow",
    "MutantRecord",
    "explain",
    "load_explanations",
    "module_rows",
    "record_from",
    "render",
]

STATUSES = (
    "killed",
    "timeout",
    "survived",
    "not-executed",
    "skipped",
    "by-rule",
    "invalid",
    "error",
    "not-run",
)
#: The output of a mutant a PRE_JUDGE rule explains (followed by the rule's argument).
RULE_PREFIX = "rule: "
SURVIVING = frozenset({"survived", "not-executed"})
REASON_PREFIXES = ("equivalent:", "unobservable over TCP:")
#: Issue 15: at least this share of the non-equivalent mutants of every module is killed.
TARGET = 0.90


@dataclass(frozen=True, slots=True, kw_only=True)
class MutantRecord:
    """One mutant and what became of it."""

    key: str
    module: str
    line: int
    operator: str
    status: str
    killer: str = ""  # the case that caught it, "crash: …" or "(target died)"
    kind: str = ""  # the judge's selection: cases, startup, not-executed
    cases: int = 0  # cases the judge selected
    diff: str = ""
    seconds: float | None = None
    rule: str = ""  # a rule's argument: why this mutant is unobservable if it survives
    function: str = ""  # the qualified name of the innermost function around the line
    line_key: str = ""  # `module:linehash`: every mutant of that line

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"unknown status {self.status!r}")


def load_explanations(path: Path) -> dict[str, str]:
    """Read equivalent.toml (`[mutants]`: key = reason). ValueError for a malformed reason.

    A key is a mutant's key, `module:linehash` (every mutant of that line) or
    `module:def:Qualified.name` (every mutant inside that function); `explain` looks them up
    in that order.
    """
    if not path.exists():
        return {}
    table = tomllib.loads(path.read_text(encoding="utf-8")).get("mutants", {})
    for key, reason in table.items():
        if not isinstance(reason, str) or not reason.startswith(REASON_PREFIXES) or "\n" in reason:
            raise ValueError(f"{path}: {key}: a reason is one line starting {REASON_PREFIXES}")
    return dict(table)


def explain(record: MutantRecord, explanations: Mapping[str, str]) -> str:
    """Return why a surviving mutant is equivalent or unobservable ("" when nothing says)."""
    for key in (
        record.key,
        record.line_key,
        f"{record.module}:def:{record.function}" if record.function else "",
    ):
        if key and key in explanations:
            return explanations[key]
    return f"(rule) {record.rule}" if record.rule else ""


def _judge_record(output: str | None) -> dict[str, Any]:
    last = (output or "").strip().splitlines()[-1:] or [""]
    try:
        record = json.loads(last[0])
    except ValueError:
        return {}
    return record if isinstance(record, dict) else {}


def record_from(
    key: str, item: Any, result: Any, timeout: float, *, rule: str = "", function: str = ""
) -> MutantRecord:
    """Build a record from a cosmic-ray work item and its result (None: not run yet)."""
    m = item.mutations[0]
    base = {"key": key, "module": str(m.module_path), "line": m.start_pos[0]}
    base |= {"operator": m.operator_name, "function": function}
    base["line_key"] = ":".join(key.split(":")[:2])
    if result is None:
        return MutantRecord(**base, status="not-run", rule=rule)
    if (result.output or "").startswith(RULE_PREFIX):
        reason = result.output[len(RULE_PREFIX) :]
        return MutantRecord(**base, status="by-rule", rule=reason, diff=result.diff or "")
    test = result.test_outcome.value if result.test_outcome is not None else ""
    judged = _judge_record(result.output)
    seconds: float | None
    if result.worker_outcome.value == "skipped":
        invalid = (result.output or "").startswith("invalid")
        status, seconds = ("invalid" if invalid else "skipped"), None
    elif test == "killed" and result.output == "timeout":
        status, seconds = "timeout", timeout
    elif test == "killed":
        status, seconds = "killed", judged.get("seconds")
    elif test == "survived":
        status = "not-executed" if judged.get("kind") == "not-executed" else "survived"
        seconds = judged.get("seconds")
    else:
        status, seconds = "error", None
    return MutantRecord(
        **base,
        status=status,
        killer=str(judged.get("killer", "")) or ("timeout" if status == "timeout" else ""),
        kind=str(judged.get("kind", "")),
        cases=int(judged.get("cases", 0)),
        diff=result.diff or "",
        seconds=seconds,
        rule=rule,
    )


@dataclass(frozen=True, slots=True, kw_only=True)
class ModuleRow:
    """The counts of one module."""

    module: str
    generated: int
    counts: Mapping[str, int]
    equivalent: int  # explained survivors
    unexplained: int

    @property
    def judged(self) -> int:
        return sum(self.counts.get(s, 0) for s in ("killed", "timeout", *SURVIVING))

    @property
    def rate(self) -> float | None:
        """Killed (timeouts included) over the judged mutants that are not explained."""
        denominator = self.judged - self.equivalent
        caught = self.counts.get("killed", 0) + self.counts.get("timeout", 0)
        return caught / denominator if denominator else None

    @property
    def sampled(self) -> bool:
        """Whether some mutants were not run (the rate is then a sample's)."""
        return self.counts.get("not-run", 0) > 0

    def interval(self, z: float = 1.96) -> tuple[float, float] | None:
        """The Wilson score interval of the rate (95 % by default); None without a rate."""
        n = self.judged - self.equivalent
        if n <= 0:
            return None
        p = (self.counts.get("killed", 0) + self.counts.get("timeout", 0)) / n
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        return max(0.0, centre - half), min(1.0, centre + half)


def module_rows(
    records: Iterable[MutantRecord], explanations: Mapping[str, str]
) -> list[ModuleRow]:
    """Return one row per module, in module order."""
    by_module: dict[str, list[MutantRecord]] = {}
    for r in records:
        by_module.setdefault(r.module, []).append(r)
    rows = []
    for module, members in sorted(by_module.items()):
        counts = {s: sum(1 for r in members if r.status == s) for s in STATUSES}
        survivors = [r for r in members if r.status in SURVIVING]
        explained = sum(1 for r in survivors if explain(r, explanations))
        rows.append(
            ModuleRow(
                module=module,
                generated=len(members),
                counts=counts,
                equivalent=explained,
                unexplained=len(survivors) - explained,
            )
        )
    return rows


def _percent(rate: float | None) -> str:
    return "–" if rate is None else f"{100 * rate:.1f} %"


def _table(rows: Sequence[ModuleRow]) -> list[str]:
    head = "| group | module | generated | run | killed | timeout | survived | not executed "
    lines = [
        head + "| equivalent | unexplained | skipped | by rule | invalid | error | not run "
        "| kill rate | judged |",
        "|---" * 17 + "|",
    ]
    for row in rows:
        c = row.counts
        ok = row.rate is not None and row.rate >= TARGET
        flag = "" if ok or row.rate is None else " **below target**"
        ci = row.interval()
        how = "full"
        if row.sampled:
            how = f"sample of {row.judged}"
            how += f", 95 % CI {_percent(ci[0])}–{_percent(ci[1])}" if ci else ""
        lines.append(
            f"| {group_of(row.module)} | {row.module} | {row.generated} | {row.judged} "
            f"| {c['killed']} | {c['timeout']} | {c['survived']} | {c['not-executed']} "
            f"| {row.equivalent} | {row.unexplained} | {c['skipped']} | {c['by-rule']} "
            f"| {c['invalid']} | {c['error']} | {c['not-run']} "
            f"| {_percent(row.rate)}{flag} | {how} |"
        )
    return lines


def _hunks(diff: str) -> str:
    """Return the diff's hunks without its file headers (they name a worker's copy)."""
    keep = [ln for ln in diff.splitlines() if not ln.startswith(("---", "+++"))]
    return "\n".join(keep).strip()


def _survivors(records: Sequence[MutantRecord], explanations: Mapping[str, str]) -> list[str]:
    lines: list[str] = []
    for r in sorted(records, key=lambda r: (r.module, r.line, r.key)):
        if r.status not in SURVIVING:
            continue
        reason = explain(r, explanations) or "**UNEXPLAINED**"
        how = "no case executes this line" if r.status == "not-executed" else f"{r.cases} cases"
        lines += [f"- `{r.key}` {r.module}:{r.line} {r.operator} ({how}): {reason}", ""]
        hunks = _hunks(r.diff).splitlines()
        if hunks:
            lines += ["  ```diff", *[f"  {ln}" for ln in hunks], "  ```", ""]
    return lines or ["(none)"]


def _timing(records: Sequence[MutantRecord]) -> str:
    times = [r.seconds for r in records if r.seconds is not None and r.status != "timeout"]
    if not times:
        return "No mutant judged yet."
    return (
        f"Time per judged mutant (judge process, timeouts excluded): mean "
        f"{statistics.fmean(times):.1f} s, median {statistics.median(times):.1f} s, "
        f"max {max(times):.1f} s over {len(times)} mutants."
    )


def _by_rule(records: Sequence[MutantRecord]) -> list[str]:
    counts: dict[tuple[str, str], int] = {}
    for r in records:
        if r.status == "by-rule":
            counts[(r.module, r.rule)] = counts.get((r.module, r.rule), 0) + 1
    return [f"- {module}: {n} × {rule}" for (module, rule), n in sorted(counts.items())] or [
        "(none)"
    ]


def render(
    records: Sequence[MutantRecord],
    explanations: Mapping[str, str],
    *,
    header: Sequence[str] = (),
) -> str:
    """Return the Markdown report."""
    rows = module_rows(records, explanations)
    used: set[str] = set()
    for r in records:
        if r.status in SURVIVING:
            fn_key = f"{r.module}:def:{r.function}"
            used.update(k for k in (r.key, r.line_key, fn_key) if k in explanations)
    stale = sorted(k for k in explanations if k not in used)
    lines = [
        "# Mutation testing of the reference server, judged by the suite",
        "",
        *header,
        "",
        f"Target (issue 15): at least {TARGET:.0%} of the non-equivalent mutants of every "
        "module killed. Kill rate = (killed + timeout) / (judged − explained survivors). "
        "Skipped: mutants inside annotations, never evaluated (`from __future__ import "
        "annotations`), so equivalent by construction and not judged. Invalid: the mutated "
        "module does not compile (cosmic-ray mutates the keyword-only marker `*`); not judged. "
        "By rule: unobservable by construction (tools/mutation/rules.py: dataclass `slots`, "
        "`kw_only` where the field order allows it, `__all__`, docstrings), explained and not "
        "judged; a survivor marked `(rule)` is explained by a rule that needs the judge's "
        "evidence (dataclass `frozen`/`repr`, log-call arguments). Judged `sample of n`: the "
        "module was judged on a seeded random sample of its judgeable mutants (a stratum per "
        "module); its rate is the sample's, with a 95 % Wilson interval.",
        "",
        _timing(records),
        "",
        *_table(rows),
        "",
        "## Survivors",
        "",
        *_survivors(records, explanations),
        "",
        "## Explained by rule without a run",
        "",
        *_by_rule(records),
        "",
        "## Explanations that match no surviving mutant (stale, or not run)",
        "",
        *([f"- `{k}`" for k in stale] or ["(none)"]),
    ]
    return "\n".join(lines) + "\n"
