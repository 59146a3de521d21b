"""Mutants of issue #15 from the cosmic-ray survivors of the delivery modules (aio/delivery.py,
aio/dispatcher.py).

Each was a survivor an implementer could plausibly write: a delivery abandoned after its last
retry that never gives back the module's delivery slot, so the module gets nothing more
(OA-DELIV-7, OA-ERR-5; DELIV-013 now posts again after the abandoned one), and a session's end
that forgets the module's queue without stopping its delivery task, so the old session's queued
and unanswered deliveries reach the next session under the name (OA-SESS-15; DELIV-016). And
one the campaign could not reach until `ack-deadline-ms` was advertised: a delivery whose
acknowledgement never comes is never failed, so it is not retried and the module is stuck
(OA-DELIV-11; DELIV-018 at a deadline of 500 ms). From the second campaign: a pushed sample
given a fresh per-module delivery state (queue, window, task) of its own, so a legacy module gets
the next sample before it acknowledged the previous one (OA-DELIV-5, OA-STREAM-14; DELIV-019), and
noreply stripped from every delivery, also towards a module that declared it, so the message is
not forwarded unchanged (OA-SESS-22; DELIV-020).
"""

from __future__ import annotations

import asyncio
from dataclasses import replace
from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.message import Message
from openair.server.aio.delivery import ModuleDelivery
from openair.server.aio.dispatcher import Dispatcher
from openair.server.core.streamspec import StoredSample


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


@mutant(
    "sample-fresh-delivery",
    "each pushed sample gets a delivery state (queue, window, task) of its own instead of the "
    "module's, so a legacy module gets the next sample before it acknowledged the previous one",
    "OA-DELIV-5",
    "OA-STREAM-14",
    cases=("DELIV-019",),
)
def _sample_fresh_delivery(mp: pytest.MonkeyPatch) -> None:
    def push_sample(
        self: Dispatcher, module: str, stream: str, sample: StoredSample, capacity: int
    ) -> None:
        md = self.modules[module] = ModuleDelivery(module, self)  # the old one is left running
        dropped = md.push_sample(stream, sample, capacity)
        if dropped:
            self.host.dropped(module, dropped, "SAMPLE_DROPPED")

    mp.setattr(Dispatcher, "push_sample", push_sample)


@mutant(
    "noreply-always-stripped",
    "noreply is dropped from every delivery, also towards a module that declared the "
    "extension, so the message it gets is not the one sent (and it answers it)",
    "OA-SESS-22",
    "OA-MSG-15",
    cases=("DELIV-020",),
)
def _noreply_always_stripped(mp: pytest.MonkeyPatch) -> None:
    def _wire_form(self: ModuleDelivery, msg: Message) -> Message:
        return replace(msg, noreply=False) if msg.noreply else msg

    mp.setattr(ModuleDelivery, "_wire_form", _wire_form)
