"""Mutants of issue #15 found by the hand-written faults (tests/faults/independent.toml).

Each was a one-line fault the suite once passed with every case green: a content glob
matched against the stripped text (fault I08, OA-RET-8, OA-RET-18), a receivedTime kept
only to the second (fault I23, OA-TIME-3) and a queue that overflows one early (fault I16,
OA-DELIV-8, once the spec said that deliveries in flight are not queued). The cases that now
catch them are RET-023, TIME-001 and DELIV-003.
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.message import Message
from openair.server.core import whiteboard
from openair.server.core.queues import DeliveryQueue
from openair.server.core.whiteboard import Whiteboard

_NS_PER_S = 1_000_000_000


@mutant(
    "glob-stripped",
    "a retrieve's content glob is matched against the text without its leading and trailing "
    "white space",
    "OA-RET-8",
    "OA-RET-18",
)
def _glob_stripped(mp: pytest.MonkeyPatch) -> None:
    original = whiteboard.text_of

    def text_of(msg: Message) -> str:
        return original(msg).strip()

    mp.setattr(whiteboard, "text_of", text_of)


@mutant(
    "received-to-the-second",
    "receivedTime is stamped to the whole second (the milliseconds of receipt are lost)",
    "OA-TIME-3",
)
def _received_to_the_second(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def stamp(self: Whiteboard, received_ns: int, *args: Any, **kwargs: Any) -> int:
            truncated = received_ns // _NS_PER_S * _NS_PER_S
            return int(original(self, truncated, *args, **kwargs))

        return stamp

    wrap(mp, Whiteboard, "stamp", make)


@mutant(
    "overflow-one-early",
    "a module's queue drops once it holds max-queue - 1 (fault I16: a full window's deliveries "
    "counted as queued, or an off-by-one)",
    "OA-DELIV-8",
    limits={"max_queue": 300},
)
def _overflow_one_early(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def push_all(self: DeliveryQueue, *args: Any, **kwargs: Any) -> list[Any]:
            victims = list(original(self, *args, **kwargs))
            if len(self._items) >= self.capacity:  # one fewer than max-queue is ever kept
                victims.append(self._drop_one())
            return victims

        return push_all

    wrap(mp, DeliveryQueue, "push_all", make)
