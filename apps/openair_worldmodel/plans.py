"""The plan engine (OA-WM-11, OA-WM-12): sans-I/O, conditions in, fires and acknowledgements out.

A plan moves through these states (spec 16.5)::

    accepted --initiation--> initiated --termination--> terminated
        \\--termination (before or with initiation)---> terminated   (never fires)
    any live state --action failed / cancel--> failed / terminated

At each evaluation the termination condition is looked at first, so a plan whose termination
holds when (or before) its initiation does is terminated without firing. An initiated plan fires
on every evaluation where its trigger holds and did not hold at the previous evaluation since
initiation (a false→true edge; at initiation the previous value counts as false).
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from dataclasses import dataclass, field

from openair.protocol.errors import ApiMisuseError
from openair_worldmodel.conditions import Condition, Lookup, evaluate, fields_of

__all__ = [
    "ACK_STATUSES",
    "Ack",
    "ControlAction",
    "Fire",
    "Plan",
    "PlanEngine",
    "PlanEvent",
    "PlanState",
    "ReportAction",
    "step",
]

ACK_STATUSES = ("accepted", "initiated", "fired", "terminated", "failed")


class PlanState(enum.Enum):
    """Where a plan is (OA-WM-11); TERMINATED and FAILED are final."""

    ACCEPTED = "accepted"
    INITIATED = "initiated"
    TERMINATED = "terminated"
    FAILED = "failed"


@dataclass(frozen=True, slots=True, kw_only=True)
class ControlAction:
    """Run the control command `type` (a message type) with `content`."""

    type: str
    content: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class ReportAction:
    """Publish a report of these (object, attribute) pairs ('' attribute: all attributes)."""

    items: tuple[tuple[str, str], ...]


Action = ControlAction | ReportAction


@dataclass(frozen=True, slots=True, kw_only=True)
class Plan:
    """A plan: name, three conditions, an action; `origin` is the module that sent it."""

    name: str
    initiation: Condition
    trigger: Condition
    termination: Condition
    action: Action
    origin: str = ""
    executor: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Ack:
    """An acknowledgement of plan progress (OA-WM-12); `count` is the number of fires so far."""

    plan: str
    status: str
    count: int = 0
    reason: str = ""

    def __post_init__(self) -> None:
        if self.status not in ACK_STATUSES:
            raise ValueError(f"unknown acknowledgement {self.status!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class Fire:
    """The plan's action is to be run now (the `fired` ack follows once it ran)."""

    plan: Plan
    count: int


PlanEvent = Ack | Fire


@dataclass(slots=True, kw_only=True)
class _Live:
    plan: Plan
    state: PlanState = PlanState.ACCEPTED
    last_trigger: bool = False
    fired: int = 0
    watched: frozenset[tuple[str, str]] = field(default_factory=frozenset)


def step(
    state: PlanState, last_trigger: bool, ini: bool, trig: bool, term: bool
) -> tuple[PlanState, bool, list[str]]:
    """Apply one evaluation to a plan's state; return (state, last trigger, what happened).

    What happened is a list of `initiated`, `fire`, `terminated` in order. Pure: the property
    tests compare it (through the engine) with an independent model of the rules.
    """
    if state in (PlanState.TERMINATED, PlanState.FAILED):
        return state, last_trigger, []  # OA-WM-11: final states never change
    if term:
        return PlanState.TERMINATED, last_trigger, ["terminated"]  # termination first
    happened: list[str] = []
    if state is PlanState.ACCEPTED:
        if not ini:
            return state, False, []
        state, last_trigger = PlanState.INITIATED, False
        happened.append("initiated")
    if trig and not last_trigger:
        happened.append("fire")  # OA-WM-11: a false→true edge of the trigger fires
    return state, trig, happened


class PlanEngine:
    """Hold the plans of one executor and evaluate them against a packet lookup."""

    def __init__(self) -> None:
        self._plans: dict[str, _Live] = {}

    def state(self, name: str) -> PlanState | None:
        """Return a plan's state, or None for a plan never accepted."""
        live = self._plans.get(name)
        return None if live is None else live.state

    def fired(self, name: str) -> int:
        """Return how many times a plan has fired."""
        live = self._plans.get(name)
        return 0 if live is None else live.fired

    def add(self, plan: Plan, lookup: Lookup) -> list[PlanEvent]:
        """Accept a plan and evaluate it once (OA-WM-12); a live plan of that name: failed."""
        old = self._plans.get(plan.name)
        if old is not None and old.state in (PlanState.ACCEPTED, PlanState.INITIATED):
            return [Ack(plan=plan.name, status="failed", reason="a live plan has this name")]
        watched = fields_of(plan.initiation) | fields_of(plan.trigger) | fields_of(plan.termination)
        live = _Live(plan=plan, watched=watched)
        self._plans[plan.name] = live
        return [Ack(plan=plan.name, status="accepted"), *self._evaluate(live, lookup)]

    def evaluate(
        self, lookup: Lookup, changed: Iterable[tuple[str, str]] | None = None
    ) -> list[PlanEvent]:
        """Evaluate the live plans (those reading a `changed` pair, or all when None)."""
        touched = None if changed is None else frozenset(changed)
        events: list[PlanEvent] = []
        for live in list(self._plans.values()):
            if touched is None or live.watched & touched or not live.watched:
                events.extend(self._evaluate(live, lookup))
        return events

    def _evaluate(self, live: _Live, lookup: Lookup) -> list[PlanEvent]:
        plan = live.plan
        ini, trig, term = (
            evaluate(plan.initiation, lookup),
            evaluate(plan.trigger, lookup),
            evaluate(plan.termination, lookup),
        )
        live.state, live.last_trigger, happened = step(
            live.state, live.last_trigger, ini, trig, term
        )
        events: list[PlanEvent] = []
        for what in happened:
            if what == "fire":
                live.fired += 1
                events.append(Fire(plan=plan, count=live.fired))
            else:
                events.append(Ack(plan=plan.name, status=what, count=live.fired))
        return events

    def action_done(self, name: str, error: str | None = None) -> list[Ack]:
        """Report the outcome of a fired action: `fired`, or `failed` (final) with the reason."""
        live = self._plans.get(name)
        if live is None:
            raise ApiMisuseError(f"no plan {name!r}")
        if error is None:
            return [Ack(plan=name, status="fired", count=live.fired)]
        if live.state in (PlanState.TERMINATED, PlanState.FAILED):
            return []
        live.state = PlanState.FAILED
        return [Ack(plan=name, status="failed", count=live.fired, reason=error)]

    def cancel(self, name: str) -> list[Ack]:
        """Terminate a live plan on request (WM.Plan.Cancel); a final plan stays as it is."""
        live = self._plans.get(name)
        if live is None or live.state in (PlanState.TERMINATED, PlanState.FAILED):
            return []
        live.state = PlanState.TERMINATED
        return [Ack(plan=name, status="terminated", count=live.fired)]
