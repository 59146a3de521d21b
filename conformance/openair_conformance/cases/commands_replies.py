"""Replies of the system components and phase sequencing across a new registration.

Who answers a KEEPALIVE or PING (OA-KEEP-2, OA-SESS-32), and that a replaced registration
starts its context at the first phase while only PhaseChange itself advances it (OA-REG-17).
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import setup_subscribe, triggers_xml, woken_by
from openair_conformance.harness import CaseContext
from openair_conformance.model import Level
from openair_conformance.registry import case

PHASE_CHANGE = "Psyclone.Module.Report.PhaseChange"


@case(
    id="SESS-070",
    title="KEEPALIVE and PING are answered by the component addressed, CNS for an empty to",
    section="6.1",
    requirements=("OA-KEEP-2", "OA-SESS-10", "OA-SESS-32", "OA-SESS-26"),
    level=Level.SHOULD,
    allowed=("KEEPALIVESUCCESS / PING_SUCCESS from CNS (empty to), CNS, Config, Psyclone, WB1",),
)
async def keepalive_answerer(ctx: CaseContext) -> None:
    """KEEPALIVE and PING with an empty `to`, then to CNS, Config, Psyclone and WB1.

    Catches: every KEEPALIVE answered from CNS, or an empty `to` echoed into the reply's
    `from` instead of naming CNS.
    """
    raw = await ctx.raw()
    me = ctx.name("K")
    for kind, answer in (("KEEPALIVE", "KEEPALIVESUCCESS"), ("PING", "PING_SUCCESS")):
        for to in ("", "CNS", "Config", "Psyclone", "WB1"):
            reply = await raw.request(Message(type=kind, sender=me, to=to))
            got = (reply.type, reply.sender)
            want = (answer, to or "CNS")
            ctx.check(
                got == want,
                f"{kind} to {to!r} was answered {got}",
                expected=f"{want} (OA-KEEP-2, OA-SESS-10, OA-SESS-32, OA-SESS-26)",
            )


def _phases(name: str, context: str, types: list[str]) -> str:
    phases = "".join(f'<phase id="P{i}">{triggers_xml(t)}</phase>' for i, t in enumerate(types))
    return f'<module name="{name}"><context name="{context}">{phases}</context></module>'


@case(
    id="CTX-040",
    title="Contexts: only PhaseChange advances a phase; a new registration starts at the first",
    section="8.9",
    requirements=("OA-REG-17", "OA-REG-14"),
    needs=("contexts",),
    residue=True,  # PhaseChange is a system type outside the run's names: it runs last
    allowed=(
        "woken by T1, T1 after another post of the module, T2 after PhaseChange, T1 after "
        "the registration is replaced",
    ),
)
async def phase_restarts(ctx: CaseContext) -> None:
    """Three phases in `<r>.S`; activate it; the module posts a type that sorts after
    PhaseChange, then PhaseChange; then it sends the same registration again.

    Catches: the position in the context kept across a new registration, and a PhaseChange
    recognised by anything but its exact type.
    """
    context = f"ConfR{ctx.run_id}Cn.S"
    sub = await ctx.module("Sub")
    names = ["T1", "T2", "T3"]
    registration = _phases(sub.name, context, [ctx.type(n) for n in names])
    await setup_subscribe(sub, registration)
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", f"Psyclone.Context:{context}", "switch")
    got = [await woken_by(ctx, sub, poster, names)]
    await sub.post("WB1", f"Z{ctx.type('NotAPhaseChange')}", "")  # sorts after PhaseChange
    got.append(await woken_by(ctx, sub, poster, names))
    await sub.post("WB1", PHASE_CHANGE, "")
    got.append(await woken_by(ctx, sub, poster, names))
    await setup_subscribe(sub, registration)
    got.append(await woken_by(ctx, sub, poster, names))
    want = [["T1"], ["T1"], ["T2"], ["T1"]]
    ctx.check(got == want, f"woken by {got}", expected=f"{want} (OA-REG-17)")
