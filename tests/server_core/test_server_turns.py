"""Whiteboard priority across modules (spec 10, OA-PRIO-5, OA-PRIO-6): turns, deterministic.

The router decides the wakeups of posts to a low- and a high-priority whiteboard (priorities
from the psySpec, OA-PRIO-6); their ranks go into `TurnOrder` in arrival order, as the delivery
tasks would ask; a starved turn (budget smaller than the work) must grant the high whiteboard's
deliveries first and defer the low ones. `TurnGate` is checked on a real loop without sleeps.
"""

from __future__ import annotations

import asyncio

import pytest
from router_harness import Harness

from openair.server.aio.scheduling import TurnGate, TurnOrder
from openair.server.core.config import parse_config
from openair.server.core.router import Delivery

SPEC = b"""<psySpec name="Turns" version="1.2">
  <whiteboard name="Low" priority="4.0"/>
  <whiteboard name="High" priority="0.5"/>
</psySpec>"""


def _wakeups(h: Harness, board: str, module: str, n: int) -> list[Delivery]:
    found = []
    for i in range(n):
        outcome = h.post(1, "Turn.Work", to=board, content=str(i))
        found += [d for d in outcome.deliveries if d.module == module]
    return found


def test_a_starved_turn_grants_the_high_priority_whiteboard_first() -> None:
    h = Harness(parse_config(SPEC, source="turns"))
    for conn, name, board in ((2, "LowReader", "Low"), (3, "HighReader", "High")):
        h.bind(conn, name)
        h.subscribe(conn, name, f'<triggers><trigger from="{board}" type="Turn.*"/></triggers>')
    low = _wakeups(h, "Low", "LowReader", 3)
    high = _wakeups(h, "High", "HighReader", 3)
    assert [d.wb_priority for d in low + high] == [4.0] * 3 + [0.5] * 3  # OA-PRIO-6
    order: TurnOrder[str] = TurnOrder()
    for label, d in [("low", x) for x in low] + [("high", x) for x in high]:  # low arrived first
        order.ask(label, wb_priority=d.wb_priority, priority=d.priority, want=1)
    first = order.release(3)
    assert [token for token, _ in first] == ["high", "high", "high"]  # OA-PRIO-5
    assert len(order) == 3  # the low whiteboard's work waits for the next turn
    assert [token for token, _ in order.release(3)] == ["low", "low", "low"]


def test_message_priority_ranks_after_whiteboard_priority_and_arrival_breaks_ties() -> None:
    order: TurnOrder[str] = TurnOrder()
    order.ask("a", wb_priority=1.0, priority=5.0, want=1)
    order.ask("b", wb_priority=1.0, priority=0.0, want=1)
    order.ask("c", wb_priority=0.0, priority=6.0, want=1)
    order.ask("d", wb_priority=1.0, priority=0.0, want=1)
    assert [t for t, _ in order.release(10)] == ["c", "b", "d", "a"]


def test_grants_share_the_budget_and_skip_dead_tokens() -> None:
    order: TurnOrder[str] = TurnOrder()
    order.ask("dead", wb_priority=0.0, priority=0.0, want=5)
    order.ask("big", wb_priority=1.0, priority=2.0, want=5)
    order.ask("small", wb_priority=1.0, priority=3.0, want=5)
    grants = order.release(7, alive=lambda token: token != "dead")
    assert grants == [("big", 5), ("small", 2)]
    assert len(order) == 0


def test_the_gate_resumes_waiting_tasks_in_rank_order_and_defers_past_the_budget() -> None:
    started: list[str] = []

    async def module(gate: TurnGate, label: str, wb_priority: float) -> None:
        await gate.turn(wb_priority=wb_priority, priority=2.0, want=1)
        started.append(label)

    async def main() -> TurnGate:
        gate = TurnGate(budget=2)
        tasks = [
            asyncio.create_task(module(gate, label, p))
            for label, p in (("low1", 3.0), ("low2", 3.0), ("high1", 0.0), ("high2", 0.0))
        ]
        await asyncio.gather(*tasks)
        return gate

    gate = asyncio.run(main())
    assert started == ["high1", "high2", "low1", "low2"]
    assert gate.deferred == 2 and gate.turns == 2


def test_the_gate_refuses_an_empty_budget() -> None:
    with pytest.raises(ValueError, match="at least 1"):
        TurnGate(budget=0)
