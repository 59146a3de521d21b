"""The asyncio adapter: one world-model module on a whiteboard, over the Python client `Module`.

`WorldModelNode` subscribes its module to `WM.*` on its robot's whiteboard, to `WM.Report` and
`WM.Hello` on the whiteboards of peer robots (SYSTEM objects, OA-WM-14) and to
`Psyclone.Module.Lost.*` on AIRCentral (presence, OA-SESS-15), posts its `WM.Hello`, and then
passes every wakeup to its `WorldModelCore`, posting what the core returns. Control actions run
through handlers registered by message type; without a handler the action is posted to the
whiteboard as a message of that type.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
import time
from collections.abc import Awaitable, Callable, Iterable, Mapping
from types import TracebackType

from openair.client import Module, WakeupEvent
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.errors import OpenAIRError
from openair_worldmodel.blackboard import Blackboard, ClassDef
from openair_worldmodel.interface import LOST_PREFIX, Outgoing, ReportFilter, WorldModelCore
from openair_worldmodel.packets import Context, Value
from openair_worldmodel.plans import ControlAction, Fire, Plan
from openair_worldmodel.wire import (
    TYPE_ACK,
    TYPE_CLASS,
    TYPE_HELLO,
    TYPE_PLAN,
    TYPE_REPORT,
    PlanAck,
    decode_ack,
    encode_class,
    encode_plan,
)

__all__ = ["ControlHandler", "WorldModelNode", "now_us"]

log = logging.getLogger("openair_worldmodel")

ControlHandler = Callable[["WorldModelNode", Fire], Awaitable[None] | None]
MessageHandler = Callable[["WorldModelNode", str, str], Awaitable[None] | None]
AIRCENTRAL = "AIRCentral"


def now_us() -> int:
    """Return the wall clock in microseconds since the epoch (packet timestamps, OA-WM-2)."""
    return time.time_ns() // 1000


class WorldModelNode:
    """A module with a world model; an async context manager."""

    def __init__(
        self,
        name: str,
        *,
        robot: str,
        whiteboard: str,
        host: str = "127.0.0.1",
        port: int = 10000,
        peers: Iterable[str] = (),
        filters: Mapping[tuple[str, str], ReportFilter] | None = None,
        clock: Callable[[], int] = now_us,
        extra_triggers: Mapping[str, MessageHandler] | None = None,
    ) -> None:
        self.core = WorldModelCore(robot=robot, module=name, whiteboard=whiteboard, filters=filters)
        self.peers = tuple(peers)
        self.clock = clock
        self.controls: dict[str, ControlHandler] = {}
        self.extra = dict(extra_triggers or {})
        self.acks: asyncio.Queue[PlanAck] = asyncio.Queue()
        self.module = Module(name, host, port, on_wakeup=self._on_wakeup)
        self._lock = asyncio.Lock()
        self._changed = asyncio.Condition()

    @property
    def name(self) -> str:
        """The module's name."""
        return self.core.module

    @property
    def blackboard(self) -> Blackboard:
        """This module's blackboard (its replica of the robot's world model)."""
        return self.core.blackboard

    async def __aenter__(self) -> WorldModelNode:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.module.close()

    async def start(self) -> None:
        """Connect, subscribe and announce the module (OA-WM-14)."""
        await self.module.connect()
        wb = self.core.whiteboard
        triggers = [
            Trigger(pattern="WM.*", whiteboard=wb),
            Trigger(pattern=LOST_PREFIX + "*", whiteboard=AIRCENTRAL),
        ]
        for peer in self.peers:
            triggers += [
                Trigger(pattern=TYPE_REPORT, whiteboard=peer),
                Trigger(pattern=TYPE_HELLO, whiteboard=peer),
            ]
        triggers += [Trigger(pattern=t, whiteboard=wb) for t in self.extra]
        await self.module.subscribe(triggers)
        await self._catch_up()
        await self._emit([self.core.hello()])

    async def _catch_up(self) -> None:
        """Apply the reports and hellos stored before this module subscribed (OA-WM-13).

        A report that also arrives as a wakeup is applied twice, which changes nothing: the
        replica keeps the greatest packet per attribute (OA-WM-6).
        """
        stored = []
        for wb in (self.core.whiteboard, *self.peers):
            for pattern in (TYPE_HELLO, TYPE_REPORT):
                spec = RetrieveSpec(whiteboard=wb, pattern=pattern, latest=0)
                stored += [(wb, m) for m in reversed(await self.module.retrieve(spec, to=wb))]
        async with self._lock:
            for wb, msg in stored:
                try:
                    outputs = self.core.receive(
                        msg.type, msg.content, peer=wb != self.core.whiteboard
                    )
                except OpenAIRError as exc:
                    log.warning("%s: cannot use stored %s: %s", self.name, msg.type, exc)
                    continue
                await self._emit(outputs)

    async def close(self) -> None:
        """Close the module (its peers see `Psyclone.Module.Lost.<name>`)."""
        await self.module.close()

    # -- local API -------------------------------------------------------------------------------

    def create(
        self, name: str, class_name: str = "Object", context: Context = Context.SURROUNDINGS
    ) -> None:
        """Create an object in the local blackboard (no I/O)."""
        self.core.blackboard.create(name, class_name, context)

    async def define(self, cls: ClassDef, *, publish: bool = False) -> None:
        """Define a class; with `publish`, send its structure as `WM.Class` (OA-WM-4)."""
        self.core.define(cls)
        if publish:
            await self._post(
                Outgoing(
                    type=TYPE_CLASS, content=encode_class(cls), whiteboard=self.core.whiteboard
                )
            )

    async def write(
        self,
        obj: str,
        attribute: str,
        value: Value,
        *,
        accuracy: float = 0.0,
        confidence: float = 1.0,
        timestamp: int | None = None,
    ) -> bool:
        """Write an observation now, then publish and evaluate plans; False if it lost."""
        won = self.note(
            obj, attribute, value, accuracy=accuracy, confidence=confidence, timestamp=timestamp
        )
        await self.flush()
        return won

    def note(
        self,
        obj: str,
        attribute: str,
        value: Value,
        *,
        accuracy: float = 0.0,
        confidence: float = 1.0,
        timestamp: int | None = None,
    ) -> bool:
        """Write without publishing (for handlers: the node publishes after they return)."""
        stamp = self.clock() if timestamp is None else timestamp
        return self.core.blackboard.write(
            obj, attribute, value, timestamp=stamp, accuracy=accuracy, confidence=confidence
        )

    async def flush(self) -> None:
        """Publish pending local changes and run the plans they affect."""
        async with self._lock:
            await self._emit(self.core.flush())
        await self._notify()

    def control(self, type_: str, handler: ControlHandler) -> None:
        """Run `handler` for control actions of this message type."""
        self.controls[type_] = handler

    async def send_plan(self, plan: Plan) -> None:
        """Send a plan to its executor through this robot's whiteboard (OA-WM-11)."""
        await self._post(
            Outgoing(type=TYPE_PLAN, content=encode_plan(plan), whiteboard=self.core.whiteboard)
        )

    async def wait_for(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Wait until `predicate()` holds after a change (no polling); False after timeout."""
        try:
            async with asyncio.timeout(timeout), self._changed:
                await self._changed.wait_for(predicate)
        except TimeoutError:
            return predicate()
        return True

    async def next_ack(self, timeout: float) -> PlanAck | None:
        """Return the next acknowledgement of a plan this module sent, or None on timeout."""
        try:
            async with asyncio.timeout(timeout):
                return await self.acks.get()
        except TimeoutError:
            return None

    # -- delivery --------------------------------------------------------------------------------

    async def _on_wakeup(self, event: WakeupEvent) -> None:
        msg = event.wakeup.trigger
        if msg is None:
            return  # a phase update
        try:
            async with self._lock:
                await self._handle(msg.type, msg.content, msg.to)
        except OpenAIRError as exc:
            log.warning("%s: cannot use %s from %s: %s", self.name, msg.type, msg.sender, exc)
        await self._notify()

    async def _handle(self, type_: str, content: str, whiteboard: str) -> None:
        if type_ in self.extra:
            await _maybe(self.extra[type_](self, type_, content))
            await self._emit(self.core.flush())
            return
        if type_ == TYPE_ACK:
            ack = decode_ack(content)
            if ack.origin == self.name:
                self.acks.put_nowait(ack)
            return
        peer = whiteboard not in (self.core.whiteboard, AIRCENTRAL)
        await self._emit(self.core.receive(type_, content, peer=peer))

    async def _emit(self, outputs: list[Outgoing | Fire]) -> None:
        for item in outputs:
            if isinstance(item, Outgoing):
                await self._post(item)
            else:
                await self._fire(item)

    async def _fire(self, fire: Fire) -> None:
        action = fire.plan.action
        if not isinstance(action, ControlAction):
            return  # report actions are run by the core
        error: str | None = None
        try:
            handler = self.controls.get(action.type)
            if handler is None:
                await self.module.post(self.core.whiteboard, action.type, action.content)
            else:
                await _maybe(handler(self, fire))
        except Exception as exc:  # an action that fails fails its plan (OA-WM-12)
            error = f"{type(exc).__name__}: {exc}"
        await self._emit(self.core.action_done(fire.plan.name, error))
        await self._emit(self.core.flush())  # what the handler wrote

    async def _post(self, item: Outgoing) -> None:
        await self.module.post(item.whiteboard, item.type, item.content, content_is_xml=True)

    async def _notify(self) -> None:
        async with self._changed:
            self._changed.notify_all()


async def _maybe(result: Awaitable[None] | None) -> None:
    if inspect.isawaitable(result):
        await result
