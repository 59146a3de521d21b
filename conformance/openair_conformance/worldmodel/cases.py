"""The world-model cases WM-001…; each cites the OA-WM requirements it checks.

A case gets a `Ctx`: the peer module, the name of the module under test, and a unique prefix
for plan and object names so that runs against the same whiteboard never meet.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from openair_conformance.model import CaseInfo, Level
from openair_conformance.worldmodel.peer import CaseFailure, Peer
from openair_worldmodel import ClassDef, ControlAction, Packet, Plan, ReportAction
from openair_worldmodel import Context as WmContext
from openair_worldmodel.conditions import parse_condition
from openair_worldmodel.wire import (
    TYPE_CANCEL,
    TYPE_CLASS,
    TYPE_HELLO,
    TYPE_PLAN,
    TYPE_REPORT,
    Cancel,
    Report,
    ReportObject,
    decode_hello,
    decode_report,
    encode_cancel,
    encode_class,
    encode_plan,
    encode_report,
)

#: The spec section of every world-model case (16, extension `worldmodel`).
SECTION = "16"


@dataclass(slots=True, kw_only=True)
class Ctx:
    """What a case works with."""

    peer: Peer
    module: str
    prefix: str
    now_us: int

    def plan(self, name: str, ini: str, trig: str, term: str, action: object = None) -> Plan:
        return Plan(
            name=f"{self.prefix}{name}",
            initiation=parse_condition(ini),
            trigger=parse_condition(trig),
            termination=parse_condition(term),
            action=action or ControlAction(type="Conform.Action"),  # type: ignore[arg-type]
            origin=self.peer.module.name,
            executor=self.module,
        )

    async def send(self, plan: Plan) -> None:
        await self.peer.post(TYPE_PLAN, encode_plan(plan))

    async def report(self, obj: str, attr: str, value: float | str, stamp: int, seq: int) -> None:
        packet = Packet(value=value, timestamp=stamp, seq=seq)
        item = ReportObject(
            name=obj, class_name="Object", context=WmContext.SURROUNDINGS, packets=((attr, packet),)
        )
        report = Report(robot="Conform", source=self.peer.module.name, objects=(item,))
        await self.peer.post(TYPE_REPORT, encode_report(report))


CaseFn = Callable[[Ctx], Awaitable[None]]


@dataclass(frozen=True, slots=True, kw_only=True)
class WmCase:
    """A case: ID, title, the requirements it cites, and its coroutine function."""

    id: str
    title: str
    requirements: tuple[str, ...]
    fn: CaseFn

    @property
    def info(self) -> CaseInfo:
        """The case as the engine and the reporters see it (spec section 16, MUST)."""
        return CaseInfo(
            id=self.id,
            title=self.title,
            section=SECTION,
            requirements=self.requirements,
            level=Level.MUST,
        )


CASES: list[WmCase] = []


def case(id: str, title: str, *requirements: str) -> Callable[[CaseFn], CaseFn]:
    def register(fn: CaseFn) -> CaseFn:
        CASES.append(WmCase(id=id, title=title, requirements=requirements, fn=fn))
        return fn

    return register


def _expect(statuses: list[str], wanted: list[str], rule: str) -> None:
    if statuses != wanted:
        raise CaseFailure(f"acknowledgements {statuses}, expected {wanted} ({rule})")


@case("WM-001", "a plan whose conditions hold fires once", "OA-WM-1", "OA-WM-11", "OA-WM-12")
async def fires_once(ctx: Ctx) -> None:
    plan = ctx.plan("Once", "true", "true", "false")
    await ctx.send(plan)
    await ctx.peer.wait(lambda: len(ctx.peer.acks_of(plan.name)) >= 3, "three acknowledgements")
    acks = ctx.peer.acks_of(plan.name)
    _expect([a.ack.status for a in acks], ["accepted", "initiated", "fired"], "OA-WM-12")
    if acks[2].ack.count != 1 or acks[2].executor != ctx.module:
        raise CaseFailure(f"fired ack {acks[2]} must count 1 and name the executor (OA-WM-12)")
    if any(a.origin != ctx.peer.module.name for a in acks):
        raise CaseFailure("an acknowledgement does not carry the plan's origin (OA-WM-12)")
    await ctx.peer.post(
        TYPE_CANCEL,
        encode_cancel(Cancel(plan=plan.name, executor=ctx.module, origin=ctx.peer.module.name)),
    )
    _expect(
        await ctx.peer.final_acks(plan.name),
        ["accepted", "initiated", "fired", "terminated"],
        "OA-WM-12",
    )


@case("WM-002", "termination with initiation: never fires", "OA-WM-11", "OA-WM-12")
async def never_fires(ctx: Ctx) -> None:
    plan = ctx.plan("Never", "true", "true", "true")
    await ctx.send(plan)
    _expect(await ctx.peer.final_acks(plan.name), ["accepted", "terminated"], "OA-WM-11")


@case("WM-003", "a plan with a bad condition is answered failed", "OA-WM-10", "OA-WM-12")
async def bad_condition(ctx: Ctx) -> None:
    name = f"{ctx.prefix}Bad"
    content = (
        f'<wmplan name="{name}" executor="{ctx.module}" origin="{ctx.peer.module.name}">'
        "<initiation>true</initiation><trigger>Pose.x.value &lt;</trigger>"
        '<termination>__import__("os")</termination><control type="Conform.Action"/></wmplan>'
    )
    await ctx.peer.post(TYPE_PLAN, content)
    _expect(await ctx.peer.final_acks(name), ["failed"], "OA-WM-10, OA-WM-12")


@case("WM-004", "a second plan with a live name is failed", "OA-WM-12")
async def duplicate_name(ctx: Ctx) -> None:
    plan = ctx.plan("Twice", "false", "false", "false")
    await ctx.send(plan)
    await ctx.peer.wait(lambda: len(ctx.peer.acks_of(plan.name)) >= 1, "acceptance")
    await ctx.send(plan)
    await ctx.peer.wait(lambda: len(ctx.peer.acks_of(plan.name)) >= 2, "the second answer")
    _expect([a.ack.status for a in ctx.peer.acks_of(plan.name)], ["accepted", "failed"], "OA-WM-12")


@case(
    "WM-005",
    "last writer wins by timestamp, whatever the order",
    "OA-WM-2",
    "OA-WM-3",
    "OA-WM-6",
    "OA-WM-7",
)
async def last_writer_wins(ctx: Ctx) -> None:
    obj = f"{ctx.prefix}Lww"
    await ctx.report(obj, "a", 2.0, ctx.now_us + 10, 1)  # newer first
    await ctx.report(obj, "a", 1.0, ctx.now_us, 2)  # then older: must change nothing
    plan = ctx.plan("Lww", "true", f"{obj}.a.value == 2", f"{obj}.a.value == 1")
    await ctx.send(plan)
    await ctx.peer.wait(lambda: len(ctx.peer.acks_of(plan.name)) >= 3, "the fire")
    _expect(
        [a.ack.status for a in ctx.peer.acks_of(plan.name)][:3],
        ["accepted", "initiated", "fired"],
        "OA-WM-6",
    )


@case("WM-006", "the trigger fires on each false-to-true edge", "OA-WM-11", "OA-WM-12")
async def edges(ctx: Ctx) -> None:
    obj = f"{ctx.prefix}Edge"
    plan = ctx.plan("Edge", "true", f"{obj}.t.value == 1", f"{obj}.end.value == 1")
    await ctx.send(plan)
    await ctx.peer.wait(lambda: len(ctx.peer.acks_of(plan.name)) >= 2, "initiation")
    stamp = ctx.now_us
    for seq, value in enumerate((1.0, 1.0, 0.0, 1.0), start=1):
        await ctx.report(obj, "t", value, stamp + seq, seq)
        fires = 1 if seq < 4 else 2
        await ctx.peer.wait(
            lambda n=fires: sum(a.ack.status == "fired" for a in ctx.peer.acks_of(plan.name)) >= n,
            f"fire {fires}",
        )
    await ctx.report(obj, "end", 1.0, stamp + 10, 10)
    statuses = await ctx.peer.final_acks(plan.name)
    _expect(statuses, ["accepted", "initiated", "fired", "fired", "terminated"], "OA-WM-11")


@case("WM-007", "a report action publishes a valid report", "OA-WM-1", "OA-WM-2", "OA-WM-7")
async def report_action(ctx: Ctx) -> None:
    obj = f"{ctx.prefix}Rep"
    await ctx.report(obj, "a", "hello", ctx.now_us, 1)
    plan = ctx.plan("Rep", "true", "true", "false", ReportAction(items=((obj, "a"),)))
    await ctx.send(plan)
    await ctx.peer.wait(lambda: any(obj in r for r in ctx.peer.reports), f"a report of {obj}")
    content = next(r for r in ctx.peer.reports if obj in r)
    ctx.peer.schema.check(content, "the report")
    report = decode_report(content)
    packets = [p for o in report.objects if o.name == obj for a, p in o.packets if a == "a"]
    if report.source != ctx.module or not packets or packets[0].value != "hello":
        raise CaseFailure(f"the report {content} does not carry {obj}.a from {ctx.module}")
    if packets[0].timestamp != ctx.now_us:
        raise CaseFailure("a reported packet must keep its observation time (OA-WM-2)")


@case("WM-008", "the module announced itself with WM.Hello", "OA-WM-14")
async def hello(ctx: Ctx) -> None:
    found = [m for m in await ctx.peer.stored(TYPE_HELLO) if m.sender == ctx.module]
    if not found:
        raise CaseFailure(f"no WM.Hello from {ctx.module} on {ctx.peer.whiteboard} (OA-WM-14)")
    ctx.peer.schema.check(found[0].content, "the WM.Hello")
    if decode_hello(found[0].content).module != ctx.module:
        raise CaseFailure("the WM.Hello names another module")


@case("WM-009", "a class received at run time gives its default", "OA-WM-4")
async def run_time_class(ctx: Ctx) -> None:
    cls = ClassDef(name=f"{ctx.prefix}Kind", attributes=(("mode", Packet(value="auto")),))
    await ctx.peer.post(TYPE_CLASS, encode_class(cls))
    obj = f"{ctx.prefix}Inst"
    item = ReportObject(
        name=obj,
        class_name=cls.name,
        context=WmContext.SURROUNDINGS,
        packets=(("other", Packet(value=1.0, timestamp=ctx.now_us, seq=1)),),
    )
    report = Report(robot="Conform", source=ctx.peer.module.name, objects=(item,))
    await ctx.peer.post(TYPE_REPORT, encode_report(report))
    plan = ctx.plan("Class", "true", f'{obj}.mode.value == "auto"', "false")
    await ctx.send(plan)
    await ctx.peer.wait(lambda: len(ctx.peer.acks_of(plan.name)) >= 3, "the fire")
