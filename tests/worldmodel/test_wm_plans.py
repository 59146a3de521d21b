"""Plan semantics (OA-WM-11, OA-WM-12): hand-written traces and a property over all orders.

The property drives a real blackboard and the engine with random sequences of attribute changes
and compares the fires and acknowledgements with a reference model written from the four steps
of spec 16.5 — separately from `plans.step`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from openair_worldmodel import ControlAction, Plan, WorldModelCore, parse_condition
from openair_worldmodel.plans import Ack, Fire, PlanEngine, PlanState, step
from openair_worldmodel.wire import TYPE_ACK, decode_ack

TRACES = json.loads(
    (Path(__file__).resolve().parents[2] / "spec/vectors/worldmodel/plan-traces.json").read_text()
)["cases"]


def _plan(name: str = "P") -> Plan:
    return Plan(
        name=name,
        initiation=parse_condition("C.ini.value == 1"),
        trigger=parse_condition("C.trig.value == 1"),
        termination=parse_condition("C.term.value == 1"),
        action=ControlAction(type="Do.It"),
        origin="Tester",
        executor="Exec",
    )


@pytest.mark.parametrize("case", TRACES, ids=lambda c: c["name"])
def test_step_follows_the_trace(case: dict[str, Any]) -> None:
    state, last = PlanState.ACCEPTED, False
    for values, expected in zip(case["steps"], case["events"], strict=True):
        state, last, happened = step(state, last, *values)
        assert happened == expected


def _drive(steps: list[tuple[bool, bool, bool]]) -> tuple[list[str], list[int]]:
    """Run a plan on a WorldModelCore, one evaluation per step; return acks and fire steps."""
    core = WorldModelCore(robot="R", module="Exec", whiteboard="WB1")
    core.blackboard.create("C")
    clock = iter(range(1, 10_000))
    first = steps[0]
    for attr, value in zip(("ini", "trig", "term"), first, strict=True):
        core.blackboard.write("C", attr, float(value), timestamp=next(clock))
    core.blackboard.drain_changes()
    acks: list[str] = []
    fires: list[int] = []

    def collect(outputs: list[Any], index: int) -> None:
        for out in outputs:
            if isinstance(out, Fire):
                fires.append(index)
                collect(core.action_done(out.plan.name), index)
            elif out.type == TYPE_ACK:
                acks.append(decode_ack(out.content).ack.status)

    collect(core.add_plan(_plan()), 0)
    for index, values in enumerate(steps[1:], start=1):
        # all three attributes change in one batch: one evaluation per step
        for attr, value in zip(("ini", "trig", "term"), values, strict=True):
            core.blackboard.write("C", attr, float(value), timestamp=next(clock))
        collect(core.flush(), index)
    return acks, fires


@pytest.mark.parametrize("case", TRACES, ids=lambda c: c["name"])
def test_core_acknowledges_the_trace(case: dict[str, Any]) -> None:
    acks, _ = _drive([tuple(s) for s in case["steps"]])
    assert acks == case["acks"]


def reference(steps: list[tuple[bool, bool, bool]]) -> list[int]:
    """The rules of 16.5 stated directly: the evaluations at which the action fires."""
    first_term = next((i for i, s in enumerate(steps) if s[2]), len(steps))
    first_ini = next((i for i, s in enumerate(steps) if s[0]), len(steps))
    if first_term <= first_ini:
        return []
    fires = []
    for i in range(first_ini, first_term):
        previous = steps[i - 1][1] if i > first_ini else False
        if steps[i][1] and not previous:
            fires.append(i)
    return fires


_steps = st.lists(st.tuples(st.booleans(), st.booleans(), st.booleans()), min_size=1, max_size=12)


@settings(max_examples=150)
@given(_steps)
def test_engine_matches_the_reference_model(steps: list[tuple[bool, bool, bool]]) -> None:
    acks, fires = _drive(steps)
    assert fires == reference(steps)
    assert acks[0] == "accepted"
    body = acks[1:]
    finals = [a for a in body if a in ("terminated", "failed")]
    assert len(finals) <= 1 and (not finals or body[-1] == finals[0])
    assert body.count("fired") == len(fires)
    if fires:
        assert body.index("initiated") < body.index("fired")


@settings(max_examples=100)
@given(st.lists(st.tuples(st.sampled_from(["ini", "trig", "term"]), st.booleans()), max_size=15))
def test_single_attribute_changes_in_any_order(changes: list[tuple[str, bool]]) -> None:
    """Changing one attribute at a time, in any order, is the same as the step sequence."""
    values = {"ini": False, "trig": False, "term": False}
    steps = [(False, False, False)]
    for attr, value in changes:
        values[attr] = value
        steps.append((values["ini"], values["trig"], values["term"]))
    core = WorldModelCore(robot="R", module="Exec", whiteboard="WB1")
    core.blackboard.create("C")
    for stamp, attr in enumerate(("ini", "trig", "term"), start=1):
        core.blackboard.write("C", attr, 0.0, timestamp=stamp)
    core.blackboard.drain_changes()
    fires = [0] if any(isinstance(o, Fire) for o in core.add_plan(_plan())) else []
    for index, (attr, value) in enumerate(changes, start=1):
        core.blackboard.write("C", attr, float(value), timestamp=10 + index)
        outputs = core.flush()
        fires += [index for o in outputs if isinstance(o, Fire)]
        for o in outputs:
            if isinstance(o, Fire):
                core.action_done(o.plan.name)
    assert fires == reference(steps)


def test_a_live_name_is_refused_and_a_failed_action_is_final() -> None:
    engine = PlanEngine()
    lookup = lambda obj, attr: None  # noqa: E731
    plan = _plan()
    assert engine.add(plan, lookup) == [Ack(plan="P", status="accepted")]
    assert engine.add(plan, lookup) == [
        Ack(plan="P", status="failed", reason="a live plan has this name")
    ]
    assert engine.state("P") is PlanState.ACCEPTED
    assert engine.action_done("P", "boom") == [
        Ack(plan="P", status="failed", count=0, reason="boom")
    ]
    assert engine.cancel("P") == []
    assert engine.state("P") is PlanState.FAILED


def test_an_unreadable_plan_is_answered_failed() -> None:
    core = WorldModelCore(robot="R", module="Exec", whiteboard="WB1")
    bad = (
        '<wmplan name="P" executor="Exec" origin="T"><initiation>true</initiation>'
        "<trigger>a.b.value &lt;</trigger><termination>false</termination>"
        '<control type="A"/></wmplan>'
    )
    (out,) = core.receive("WM.Plan", bad)
    assert not isinstance(out, Fire)
    ack = decode_ack(out.content)
    assert (ack.ack.status, ack.origin, ack.executor) == ("failed", "T", "Exec")
    assert "condition" in ack.ack.reason
