"""Internal module code for test_server_io_internal.py, named in its psySpecs (OA-CONF-8).

Each handler answers the trigger message of a wakeup; phase updates (no trigger) are ignored.
"""

from __future__ import annotations

import threading

from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.internal import InternalModule

#: Set by the test to let `blocker` return; `blocked` is set once it is waiting.
RELEASE = threading.Event()
BLOCKED = threading.Event()
#: The names of the threads the handlers ran on.
THREADS: list[str] = []


def _trigger(msg: Message) -> Message | None:
    return parse_wakeup(msg).trigger if msg.type == "AIR.Instruct.Wakeup" else None


class Echo:
    """An async class handler: post `Int.Pong` with the trigger's content, on the loop."""

    async def __call__(self, module: InternalModule, msg: Message) -> None:
        trigger = _trigger(msg)
        if trigger is not None:
            THREADS.append(threading.current_thread().name)
            module.post("WB1", "Int.Pong", trigger.content)


def blocker(module: InternalModule, msg: Message) -> None:
    """A blocking function: wait for the test's RELEASE, then post `Int.Done` (a worker thread)."""
    trigger = _trigger(msg)
    if trigger is None:
        return
    THREADS.append(threading.current_thread().name)
    BLOCKED.set()
    if not RELEASE.wait(timeout=30):
        raise TimeoutError("never released")
    module.post("WB1", "Int.Done", trigger.content)


async def faulty(module: InternalModule, msg: Message) -> None:
    """Raise on content `boom`; post `Int.Ok` otherwise."""
    trigger = _trigger(msg)
    if trigger is None:
        return
    if trigger.content == "boom":
        raise RuntimeError("the module's own bug")
    module.post("WB1", "Int.Ok", trigger.content)
