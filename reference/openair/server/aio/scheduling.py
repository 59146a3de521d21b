"""Turns: whiteboard priority across modules (spec section 10, OA-PRIO-5, OA-PRIO-6).

Each module has its own delivery task (delivery.py); without coordination the event loop runs
them in the order they woke up, whatever whiteboard their work came from. Here a module's task
asks for a **turn** before it starts a burst of deliveries, with the **rank** of the delivery it
holds, (whiteboard priority, message priority), lower first. Once per event-loop iteration the
gate grants the waiting modules, in rank order (arrival order on equal ranks), at most
`budget` deliveries in all; the rest wait for the next iteration, where new, better-ranked work
may overtake them. So under CPU starvation the low-priority whiteboards' deliveries are the ones
that queue up (and at `max-queue` are dropped, OA-DELIV-9), as the paper asks.

`TurnOrder` is the sans-I/O core (tested deterministically); `TurnGate` runs it on the loop.
"""

from __future__ import annotations

import asyncio
import heapq
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

__all__ = ["DEFAULT_TURN_BUDGET", "TurnGate", "TurnOrder"]

#: Deliveries started per loop iteration over all modules (OA-PRIO-5's turn budget).
DEFAULT_TURN_BUDGET = 1024

T = TypeVar("T")


@dataclass(order=True, slots=True)
class _Ask(Generic[T]):
    rank: tuple[float, float]  # (whiteboard priority, message priority): lower goes first
    seq: int  # arrival: first come, first served on equal ranks
    want: int = field(compare=False)
    token: T = field(compare=False)


class TurnOrder(Generic[T]):
    """The modules waiting for a turn, in rank order (OA-PRIO-5)."""

    def __init__(self) -> None:
        self._heap: list[_Ask[T]] = []
        self._seq = 0

    def __len__(self) -> int:
        return len(self._heap)

    def ask(self, token: T, *, wb_priority: float, priority: float, want: int) -> None:
        """Wait for a turn to start up to `want` deliveries whose first has this rank."""
        self._seq += 1
        heapq.heappush(self._heap, _Ask((wb_priority, priority), self._seq, max(want, 1), token))

    def release(
        self, budget: int, *, alive: Callable[[T], bool] = lambda _: True
    ) -> list[tuple[T, int]]:
        """Grant one turn: (token, deliveries granted) best rank first, at most `budget` in all.

        Tokens for which `alive` is false (a task cancelled while it waited) are dropped
        without using the budget; the rest stay for the next turn.
        """
        grants: list[tuple[T, int]] = []
        left = budget
        while self._heap and left > 0:
            ask = heapq.heappop(self._heap)
            if not alive(ask.token):
                continue
            grant = min(ask.want, left)
            left -= grant
            grants.append((ask.token, grant))
        return grants


class TurnGate:
    """`TurnOrder` on an asyncio loop: one release per loop iteration while modules wait."""

    def __init__(self, budget: int = DEFAULT_TURN_BUDGET) -> None:
        if budget < 1:
            raise ValueError(f"the turn budget must be at least 1, not {budget}")
        self.budget = budget
        self.turns = 0  # releases made
        self.deferred = 0  # asks carried over to a later turn (the gate was saturated)
        self._order: TurnOrder[asyncio.Future[int]] = TurnOrder()
        self._scheduled = False

    @property
    def waiting(self) -> bool:
        """Whether a module waits for a turn (or a release is due in this loop iteration)."""
        return self._scheduled or bool(self._order)

    async def turn(self, *, wb_priority: float, priority: float, want: int) -> int:
        """Wait for this module's turn; return how many deliveries it may start now (>= 1)."""
        loop = asyncio.get_running_loop()
        future: asyncio.Future[int] = loop.create_future()
        self._order.ask(future, wb_priority=wb_priority, priority=priority, want=want)
        if not self._scheduled:
            self._scheduled = True
            # call_soon: every task woken in this iteration asks before the release runs.
            loop.call_soon(self._release)
        return await future

    def _release(self) -> None:
        self._scheduled = False
        self.turns += 1
        for future, grant in self._order.release(self.budget, alive=lambda f: not f.done()):
            future.set_result(grant)
        if self._order:
            self.deferred += len(self._order)
            self._scheduled = True
            asyncio.get_running_loop().call_soon(self._release)
