"""The world-model interface, sans-I/O: messages in, messages to post and actions to run out.

`WorldModelCore` joins one module's blackboard, its plan engine and its report publisher. The
asyncio adapter (`node.py`) feeds it the `WM.` messages its module receives and posts what it
returns; nothing here reads a clock or touches a socket. Received reports are applied with
last-writer-wins (OA-WM-6); reports from another robot's whiteboard bring only SYSTEM objects
(OA-WM-14); local changes are published, filtered (OA-WM-9); plans addressed to this module are
run (OA-WM-11) and acknowledged (OA-WM-12).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from openair.protocol.errors import ApiMisuseError, ContentInvalidError
from openair_worldmodel.blackboard import Blackboard, Change, ClassDef
from openair_worldmodel.packets import Context, Packet
from openair_worldmodel.plans import Ack, Fire, Plan, PlanEngine, PlanEvent, ReportAction
from openair_worldmodel.wire import (
    TYPE_ACK,
    TYPE_CANCEL,
    TYPE_CLASS,
    TYPE_HELLO,
    TYPE_PLAN,
    TYPE_REPORT,
    Hello,
    PlanAck,
    Report,
    ReportObject,
    decode_cancel,
    decode_class,
    decode_hello,
    decode_plan,
    decode_report,
    encode_ack,
    encode_hello,
    encode_report,
)

__all__ = ["LOST_PREFIX", "Outgoing", "ReportFilter", "WorldModelCore"]

LOST_PREFIX = "Psyclone.Module.Lost."


@dataclass(frozen=True, slots=True, kw_only=True)
class Outgoing:
    """A message to post: its type and XML content, to `whiteboard`."""

    type: str
    content: str
    whiteboard: str


@dataclass(frozen=True, slots=True, kw_only=True)
class ReportFilter:
    """Publish a packet only when it moved more than `min_change` (numbers; other values: when
    they differ) and `min_interval_us` after the last published one (OA-WM-9)."""

    min_change: float = 0.0
    min_interval_us: int = 0

    def passes(self, new: Packet, last: Packet | None) -> bool:
        """True when `new` is to be published after `last`."""
        if last is None:
            return True
        if new.timestamp - last.timestamp < self.min_interval_us:
            return False
        if self.min_change <= 0:
            return True
        if isinstance(new.value, float) and isinstance(last.value, float):
            return abs(new.value - last.value) > self.min_change
        return new.value != last.value


Output = Outgoing | Fire


class WorldModelCore:
    """One module's world model: blackboard, plans, reports and presence."""

    def __init__(
        self,
        *,
        robot: str,
        module: str,
        whiteboard: str,
        filters: Mapping[tuple[str, str], ReportFilter] | None = None,
        default_filter: ReportFilter | None = None,
    ) -> None:
        self.robot, self.module, self.whiteboard = robot, module, whiteboard
        self.blackboard = Blackboard(robot=robot, source=module)
        self.engine = PlanEngine()
        self.filters = dict(filters or {})
        self.default_filter = default_filter or ReportFilter()
        self.plans: dict[str, Plan] = {}
        self.modules: dict[str, str] = {}  # module -> robot, from hellos (OA-WM-14)
        self.present: dict[str, set[str]] = {}  # robot -> its modules still connected
        self._sent: dict[tuple[str, str], Packet] = {}

    # -- local side ----------------------------------------------------------------------------

    def hello(self) -> Outgoing:
        """Return this module's `WM.Hello` (post it on connecting)."""
        hello = Hello(robot=self.robot, module=self.module, whiteboard=self.whiteboard)
        return Outgoing(type=TYPE_HELLO, content=encode_hello(hello), whiteboard=self.whiteboard)

    def define(self, cls: ClassDef) -> ClassDef:
        """Define a class locally (publish it with wire.encode_class to share its structure)."""
        return self.blackboard.define_class(cls)

    def lookup(self, obj: str, attribute: str) -> Packet | None:
        """Return the packet conditions see: read functions applied, stale objects absent."""
        found = self.blackboard.objects.get(obj)
        if found is None or found.stale:
            return None  # OA-WM-10, OA-WM-14: stale facts make no predicate true
        return self.blackboard.read(obj, attribute)

    def flush(self) -> list[Output]:
        """Publish the local changes since the last flush and evaluate the plans on them."""
        changes = self.blackboard.drain_changes()
        out: list[Output] = []
        report = self._report([c for c in changes if c.local])
        if report is not None:
            out.append(report)
        if changes:
            out.extend(self._plan_outputs(self.engine.evaluate(self.lookup)))
        return out

    def _report(self, changes: list[Change]) -> Outgoing | None:
        latest: dict[tuple[str, str], Change] = {}
        for change in changes:
            latest[(change.object, change.attribute)] = change
        objects: dict[str, list[tuple[str, Packet]]] = {}
        meta: dict[str, Change] = {}
        for key, change in latest.items():
            rule = self.filters.get(key, self.default_filter)
            if not rule.passes(change.packet, self._sent.get(key)):
                continue  # OA-WM-9: filtered in value or time
            self._sent[key] = change.packet
            objects.setdefault(change.object, []).append((change.attribute, change.packet))
            meta[change.object] = change
        if not objects:
            return None
        return self._encode(objects, meta)

    def _encode(
        self, objects: dict[str, list[tuple[str, Packet]]], meta: Mapping[str, Change]
    ) -> Outgoing:
        items = tuple(
            ReportObject(
                name=name,
                class_name=meta[name].class_name,
                context=meta[name].context,
                packets=tuple(packets),
            )
            for name, packets in objects.items()
        )
        report = Report(robot=self.robot, source=self.module, objects=items)
        return Outgoing(type=TYPE_REPORT, content=encode_report(report), whiteboard=self.whiteboard)

    def report_now(self, items: tuple[tuple[str, str], ...]) -> Outgoing | None:
        """Publish the current packets of `items` unfiltered (a report action, OA-WM-11)."""
        objects: dict[str, list[tuple[str, Packet]]] = {}
        meta: dict[str, Change] = {}
        for name, attribute in items:
            obj = self.blackboard.objects.get(name)
            if obj is None:
                continue
            for attr in [attribute] if attribute else sorted(obj.packets):
                packet = obj.packets.get(attr)
                if packet is None:
                    continue
                objects.setdefault(name, []).append((attr, packet))
                meta[name] = Change(
                    object=name,
                    class_name=obj.class_name,
                    context=obj.context,
                    attribute=attr,
                    packet=packet,
                    local=False,
                )
        return self._encode(objects, meta) if objects else None

    # -- plans ---------------------------------------------------------------------------------

    def _ack(self, ack: Ack) -> Outgoing:
        plan = self.plans.get(ack.plan)
        wire = PlanAck(ack=ack, executor=self.module, origin=plan.origin if plan else "")
        return Outgoing(type=TYPE_ACK, content=encode_ack(wire), whiteboard=self.whiteboard)

    def _plan_outputs(self, events: list[PlanEvent]) -> list[Output]:
        out: list[Output] = []
        for event in events:
            if isinstance(event, Fire) and isinstance(event.plan.action, ReportAction):
                report = self.report_now(event.plan.action.items)  # run at once: no I/O needed
                if report is not None:
                    out.append(report)
                out.extend(self._ack(a) for a in self.engine.action_done(event.plan.name))
            elif isinstance(event, Fire):
                out.append(event)  # the adapter runs the control action, then action_done()
            else:
                out.append(self._ack(event))
        return out

    def add_plan(self, plan: Plan) -> list[Output]:
        """Accept a plan for this module and evaluate it once (OA-WM-11, OA-WM-12)."""
        events = self.engine.add(plan, self.lookup)
        first = events[0]
        if isinstance(first, Ack) and first.status == "failed":  # a live plan has this name
            wire = PlanAck(ack=first, executor=self.module, origin=plan.origin)
            return [Outgoing(type=TYPE_ACK, content=encode_ack(wire), whiteboard=self.whiteboard)]
        self.plans[plan.name] = plan
        return self._plan_outputs(events)

    def action_done(self, name: str, error: str | None = None) -> list[Output]:
        """Acknowledge a control action that ran (`fired`) or failed (`failed`, final)."""
        return [self._ack(a) for a in self.engine.action_done(name, error)]

    # -- received messages ---------------------------------------------------------------------

    def receive(self, type_: str, content: str, *, peer: bool = False) -> list[Output]:
        """Handle one received message; `peer` marks one from another robot's whiteboard.

        Content that cannot be read raises ContentInvalidError; for a plan addressed to this
        module it is acknowledged `failed` instead (OA-WM-12) when the plan's name can be read.
        """
        if type_.startswith(LOST_PREFIX):
            return self.lost(type_[len(LOST_PREFIX) :])
        if type_ == TYPE_REPORT:
            return self.apply_report(decode_report(content), peer=peer)
        if type_ == TYPE_HELLO:
            hello = decode_hello(content)
            self.modules[hello.module] = hello.robot
            self.present.setdefault(hello.robot, set()).add(hello.module)
            return []
        if peer:
            return []  # OA-WM-14: another robot's plans and classes are not ours
        if type_ == TYPE_PLAN:
            return self._receive_plan(content)
        if type_ == TYPE_CANCEL:
            cancel = decode_cancel(content)
            if cancel.executor != self.module:
                return []
            return [self._ack(a) for a in self.engine.cancel(cancel.plan)]
        if type_ == TYPE_CLASS:
            self._receive_class(content)
        return []

    def _receive_plan(self, content: str) -> list[Output]:
        try:
            plan = decode_plan(content)
        except ContentInvalidError as exc:
            return self._refuse(content, exc.detail)
        if plan.executor != self.module:
            return []
        return self.add_plan(plan)

    def _refuse(self, content: str, reason: str) -> list[Output]:
        from openair.protocol.objects import parse_root  # only needed for this rare path

        try:
            root = parse_root(content, ("wmplan",), ContentInvalidError)
        except ContentInvalidError:
            return []
        if root.get("executor") != self.module or not root.get("name"):
            return []
        ack = Ack(plan=root.get("name", ""), status="failed", reason=reason)
        wire = PlanAck(ack=ack, executor=self.module, origin=root.get("origin", ""))
        return [Outgoing(type=TYPE_ACK, content=encode_ack(wire), whiteboard=self.whiteboard)]

    def _receive_class(self, content: str) -> None:
        cls = decode_class(content)
        try:
            self.blackboard.define_class(cls)  # OA-WM-4: a class received at run time
        except ApiMisuseError as exc:
            raise ContentInvalidError(str(exc)) from None

    def apply_report(self, report: Report, *, peer: bool = False) -> list[Output]:
        """Apply a report's packets by last-writer-wins (OA-WM-6), then evaluate plans."""
        bb = self.blackboard
        for item in report.objects:
            if peer and item.context is not Context.SYSTEM:
                continue  # OA-WM-14: robots' models intersect only in SYSTEM objects
            if item.class_name not in bb.classes:
                bb.define_class(ClassDef(name=item.class_name))  # structure-only stand-in
            obj = bb.create(item.name, item.class_name, item.context, owner=report.robot)
            for attribute, packet in item.packets:
                if bb.put(item.name, attribute, packet, local=False) and obj.owner == report.robot:
                    obj.stale = False  # OA-WM-14: a newer packet from the owner is fresh
        return self.flush()

    def lost(self, module: str) -> list[Output]:
        """A module is gone: when it was its robot's last, mark that robot's facts stale."""
        robot = self.modules.pop(module, None)
        if robot is None or robot == self.robot:
            return []
        remaining = self.present.get(robot, set())
        remaining.discard(module)
        if remaining:
            return []
        stale = self.blackboard.mark_stale(robot)  # OA-WM-14
        if not stale:
            return []
        return self._plan_outputs(self.engine.evaluate(self.lookup))
