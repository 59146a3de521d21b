"""Mutants of issue #15 from the cosmic-ray survivors of the delivery modules (aio/delivery.py,
aio/dispatcher.py).

Each was a survivor an implementer could plausibly write: a delivery abandoned after its last
retry that never gives back the module's delivery slot, so the module gets nothing more
(OA-DELIV-7, OA-ERR-5; DELIV-013 now posts again after the abandoned one), and a session's end
that forgets the module's queue without stopping its delivery task, so the old session's queued
and unanswered deliveries reach the next session under the name (OA-SESS-15; DELIV-016). And
one the campaign could not reach until `ack-deadline-ms` was advertised: a delivery whose
acknowledgement never comes is never failed, so it is not retried and the module is stuck
(OA-DELIV-11; DELIV-018 at a deadline of 500 ms).
"""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.server.aio.delivery import ModuleDelivery
from openair.server.aio.dispatcher import Dispatcher


async def _never() -> None:
    await asyncio.Event().wait()


@mutant(
    "abandoned-holds-slot",
    "a delivery abandoned after its last retry keeps the module's delivery slot for ever, so "
    "the module gets nothing more",
    "OA-DELIV-7",
    "OA-ERR-5",
    cases=("DELIV-013",),
)
def _abandoned_holds_slot(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _failed(self: ModuleDelivery, attempt: Any, reason: str) -> None:
            original(self, attempt, reason)
            if attempt.tries >= self._d.options.retries:  # abandoned: the slot is not let go
                self._spawn(_never())

        return _failed

    wrap(mp, ModuleDelivery, "_failed", make)


@mutant(
    "discard-keeps-task",
    "when a module's session ends its queue is forgotten but its delivery task is not stopped: "
    "the old session's deliveries go on, to the next session under the name",
    "OA-SESS-15",
    cases=("DELIV-016",),
)
def _discard_keeps_task(mp: pytest.MonkeyPatch) -> None:
    async def discard(self: Dispatcher, module: str) -> int:
        self.modules.pop(module, None)  # neither stopped nor its queue cleared
        return 0

    mp.setattr(Dispatcher, "discard", discard)


@mutant(
    "ack-deadline-ignored",
    "a delivery whose acknowledgement never comes is never treated as failed: its connection "
    "stays open, it is not retried, and the module gets nothing more",
    "OA-DELIV-11",
    limits={"ack_deadline_ms": 500},
    cases=("DELIV-018",),
)
def _ack_deadline_ignored(mp: pytest.MonkeyPatch) -> None:
    def _check_deadlines(self: ModuleDelivery) -> None:
        self._timer = None  # overdue deliveries are left as they are

    mp.setattr(ModuleDelivery, "_check_deadlines", _check_deadlines)
