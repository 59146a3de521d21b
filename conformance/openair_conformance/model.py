"""Values the conformance suite passes around: cases, verdicts, traces, results and run events.

The engine produces the events (`RunStarted`, `CaseStarted`, `CaseFinished`, `RunFinished`);
reporters are handlers of that stream (`Reporter.handle`, then `Reporter.close`). A case signals
its outcome by returning (pass) or by raising one of `Fail`, `Timing`, `Inconclusive` or
`NotApplicable`; the engine turns that into a `Verdict` according to the case's `Level`
(README, "Verdicts").
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

__all__ = [
    "CASE_ID_PATTERN",
    "CaseFinished",
    "CaseInfo",
    "CaseResult",
    "CaseStarted",
    "Event",
    "Fail",
    "Inconclusive",
    "Level",
    "NotApplicable",
    "Reporter",
    "RunFinished",
    "RunStarted",
    "RunSummary",
    "ServerInfo",
    "TargetDeath",
    "Timing",
    "TraceEntry",
    "Verdict",
]

#: A case ID: an upper-case group, a dash and three digits ("MATCH-003"). Stable, never reused.
CASE_ID_PATTERN = r"^[A-Z]+-[0-9]{3}$"
_CASE_ID_RE = re.compile(CASE_ID_PATTERN)
_REQ_ID_RE = re.compile(r"^OA-[A-Z]+-[0-9]+$")
_SECTION_RE = re.compile(r"^[0-9]+(\.[0-9]+)*$")
_DIRECTIONS = frozenset({"out", "in", "note"})


class Level(enum.Enum):
    """The strongest requirement level a case checks; it decides what a failure means."""

    MUST = "MUST"
    SHOULD = "SHOULD"
    MAY = "MAY"
    INFO = "INFO"


class Verdict(enum.Enum):
    """The outcome of one case (README, "Verdicts")."""

    PASS = "pass"
    PASS_NONSTRICT = "pass-nonstrict"
    INFORMATIONAL = "informational"
    NOT_APPLICABLE = "not-applicable"
    EXPECTED_FAILURE = "expected-failure"
    UNEXPECTED_PASS = "unexpected-pass"
    FAIL = "fail"
    TIMING = "timing"
    INCONCLUSIVE = "inconclusive"
    ERROR = "error"


@dataclass(frozen=True, slots=True, kw_only=True)
class CaseInfo:
    """What a case is: its stable ID, what it checks, and what it needs from the server."""

    id: str
    title: str
    section: str
    requirements: tuple[str, ...]
    level: Level
    needs: frozenset[str] = frozenset()
    serial: bool = False
    allowed: tuple[str, ...] = ()
    #: The case may leave on a whiteboard what no namespace can hold (a message without a
    #: type, which a legacy server stores and matches as a prefix of every pattern, DEV-1 and
    #: DEV-17): it runs after every other case, so that no order of the others meets it.
    residue: bool = False

    def __post_init__(self) -> None:
        if not _CASE_ID_RE.match(self.id):
            raise ValueError(f"case id {self.id!r} does not match {CASE_ID_PATTERN}")
        if not self.title.strip() or "\n" in self.title:
            raise ValueError(f"{self.id}: the title must be one non-empty line")
        if not _SECTION_RE.match(self.section):
            raise ValueError(f"{self.id}: invalid section {self.section!r}")
        if not self.requirements:
            raise ValueError(f"{self.id}: a case must cite at least one requirement")
        for req in self.requirements:
            if not _REQ_ID_RE.match(req):
                raise ValueError(f"{self.id}: invalid requirement id {req!r}")

    @property
    def group(self) -> str:
        """The ID's group ("MATCH" for "MATCH-003")."""
        return self.id.split("-", 1)[0]

    @property
    def top_section(self) -> str:
        """The top-level spec section ("8" for "8.7")."""
        return self.section.split(".", 1)[0]


@dataclass(frozen=True, slots=True, kw_only=True)
class TraceEntry:
    """One line of a case's trace: a frame in or out, raw bytes, or a note."""

    t: float
    conn: str
    direction: str
    tag: str
    text: str

    def __post_init__(self) -> None:
        if self.direction not in _DIRECTIONS:
            raise ValueError(f"trace direction must be one of {sorted(_DIRECTIONS)}")


@dataclass(frozen=True, slots=True, kw_only=True)
class CaseResult:
    """The judged outcome of one case, with the evidence."""

    info: CaseInfo
    verdict: Verdict
    message: str = ""
    expected: str = ""
    trace: tuple[TraceEntry, ...] = ()
    divergence: int | None = None
    duration: float = 0.0
    repro: str = ""
    measurements: tuple[tuple[str, float], ...] = ()
    expectation_reason: str = ""
    #: The target stopped answering during this case (the liveness probe after it failed).
    target_died: bool = False
    #: The case was interrupted by the target's death and run again once after a restart
    #: (`--on-target-death restart-cmd`); `message` says what the first attempt gave.
    rerun_after_restart: bool = False


@dataclass(frozen=True, slots=True, kw_only=True)
class ServerInfo:
    """What the probe learned about the server at the start of a run.

    `legacy` is true when GET_CAPABILITIES was answered UNKNOWN_COMMAND (OA-CAP-2).
    `capabilities` are the advertised extension names. `server` and `protocol` are the
    attributes of `<capabilities>` (empty for a legacy server); they are additions to the
    contract of CONFORMANCE.md, with defaults.
    """

    legacy: bool
    capabilities: tuple[str, ...] = ()
    limits: tuple[tuple[str, int], ...] = ()
    rtt_ms: float = 0.0
    server: str = ""
    protocol: str = ""

    def has(self, extension: str) -> bool:
        """Return whether the server advertised `extension` (names are case-sensitive)."""
        return extension in self.capabilities

    def limit(self, name: str, default: int) -> int:
        """Return the advertised limit `name`, or `default` (the spec's default, OA-CAP-2)."""
        return next((value for key, value in self.limits if key == name), default)


@dataclass(frozen=True, slots=True, kw_only=True)
class TargetDeath:
    """The target stopped answering: during which case, what the probe saw, what was done.

    `action` is `stopped` (no further case started), `continued` (the run went on),
    `restarted` (the restart command brought it back) or `restart-failed`. `in_flight` lists
    the other cases running at the time (with `--jobs` above 1 any of them may be the cause).
    """

    case: str
    detail: str
    action: str
    in_flight: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class RunSummary:
    """Totals of a run; `counts` holds one pair per verdict that occurred, in Verdict order.

    `latencies` holds measured results over the whole run (e.g. post_to_wakeup_p50_ms).
    `vacuous` lists the IDs of cases that passed without observing what they check (the case
    said so with `CaseContext.vacuous`). `unknown_expectations` lists the expectations entries
    that match no registered case. `results` (an addition to CONFORMANCE.md) holds every result
    in case-ID order.
    """

    counts: tuple[tuple[Verdict, int], ...] = ()
    duration: float = 0.0
    latencies: tuple[tuple[str, float], ...] = ()
    vacuous: tuple[str, ...] = ()
    unknown_expectations: tuple[str, ...] = ()
    results: tuple[CaseResult, ...] = field(default=(), repr=False)
    #: Every time the target died during the run, in order (exit code 5).
    target_deaths: tuple[TargetDeath, ...] = ()
    #: Cases selected but never run (the run stopped when the target died).
    not_run: tuple[str, ...] = ()

    def count(self, verdict: Verdict) -> int:
        """Return how many cases ended with `verdict`."""
        return dict(self.counts).get(verdict, 0)

    @property
    def total(self) -> int:
        """The number of cases judged."""
        return sum(n for _, n in self.counts)


@dataclass(frozen=True, slots=True, kw_only=True)
class RunStarted:
    """The probe succeeded and `cases` cases are about to run."""

    target: str
    started: float
    options: dict[str, str]
    server: ServerInfo
    cases: int


@dataclass(frozen=True, slots=True, kw_only=True)
class CaseStarted:
    """A case has started (cases run in parallel, so CaseStarted events may interleave)."""

    info: CaseInfo


@dataclass(frozen=True, slots=True, kw_only=True)
class CaseFinished:
    """A case has been judged."""

    result: CaseResult


@dataclass(frozen=True, slots=True, kw_only=True)
class RunFinished:
    """Every selected case has been judged."""

    summary: RunSummary


Event = RunStarted | CaseStarted | CaseFinished | RunFinished


@runtime_checkable
class Reporter(Protocol):
    """A handler of the engine's event stream; `close` is called once, after the last event."""

    def handle(self, event: Event) -> None: ...

    def close(self) -> None: ...


class Fail(Exception):
    """The server broke the protocol: what happened, what was allowed, and where it diverged."""

    def __init__(self, message: str, expected: str = "", divergence_note: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.expected = expected
        self.divergence_note = divergence_note
        #: Index into the trace where behaviour diverged (set by CaseContext.fail).
        self.divergence: int | None = None


class Timing(Exception):
    """The expected behaviour happened, but only after the deadline (within the grace)."""


class Inconclusive(Exception):
    """The suite could not decide (for example a setup step was refused)."""


class NotApplicable(Exception):
    """The case needs something the server lacks."""
