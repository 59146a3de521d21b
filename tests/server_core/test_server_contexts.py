"""Contexts and phases (spec 8.9, OA-REG-13..18) in the sans-I/O core: `Contexts` and the router."""

from __future__ import annotations

from router_harness import EXTENSIONS, Harness, wakeups

from openair.protocol.content import Phase, Registration, RegistrationForm
from openair.protocol.wakeup import parse_wakeup
from openair.server.core.contexts import Contexts, context_of

CTX = EXTENSIONS | {"contexts"}


def _reg(*phases: tuple[str, str]) -> Registration:
    return Registration(
        module="M",
        form=RegistrationForm.SPEC,
        phases=tuple(Phase(name=name, context=context) for context, name in phases),
    )


def _name(phase: Phase | None) -> str | None:
    return phase.name if phase is not None else None


def test_one_active_context_per_root_and_ancestors_change_nothing() -> None:
    c = Contexts()
    assert c.active() == ("psyclone.system.ready",)
    assert c.activate("R.A.B") and not c.activate("R.A") and not c.activate("r.a.b")
    assert c.activate("R.C") and c.since("R.A") is None and c.since("R") is not None
    assert c.activate("S.X") and c.active() == ("psyclone.system.ready", "r.c", "s.x")


def test_the_latest_context_wins_and_the_deeper_one_on_a_tie() -> None:
    c = Contexts()
    reg = _reg(("R.A", "PA"), ("R.A.B", "PAB"), ("S.X", "PX"))
    assert c.phase("M", reg) is None
    c.activate("R.A.B")
    assert _name(c.phase("M", reg)) == "PAB"  # R.A and R.A.B came together: the deeper
    c.activate("S.X")
    assert _name(c.phase("M", reg)) == "PX"
    c.activate("R.A.B.C")  # a refinement: R.A.B stays in force since its old activation
    assert _name(c.phase("M", reg)) == "PX"
    c.activate("R.A")  # an ancestor: nothing changes
    assert _name(c.phase("M", reg)) == "PX"


def test_phase_change_steps_wraps_and_restarts_on_reentry() -> None:
    c = Contexts()
    reg = _reg(("R.S", "P1"), ("R.S", "P2"), ("R.S", "P3"))
    c.activate("R.S")
    seen = [_name(c.phase("M", reg))]
    for _ in range(3):
        assert c.advance("M", reg)
        seen.append(_name(c.phase("M", reg)))
    assert seen == ["P1", "P2", "P3", "P1"]
    c.advance("M", reg)
    c.activate("R.T")
    assert c.phase("M", reg) is None and not c.advance("M", reg)
    c.activate("R.S")
    assert _name(c.phase("M", reg)) == "P1"
    c.advance("M", reg)
    c.forget("M")  # a new registration starts at the first phase
    assert _name(c.phase("M", reg)) == "P1"


def test_context_names_that_activate_nothing() -> None:
    assert context_of("Psyclone.Context:A.B") == "A.B"
    assert [context_of(t) for t in ("Psyclone.Context:", "Psyclone.Context:A..B", "X.Y")] == [
        None,
        None,
        None,
    ]


REG = (
    '<module name="Sub"><context name="R.A"><phase id="PA">'
    '<triggers><trigger from="WB1" type="T.A"/></triggers></phase></context></module>'
)


def test_the_router_switches_phase_and_sends_a_phase_update() -> None:
    h = Harness(extensions=CTX)
    h.bind(1, "Sub")
    first = h.subscribe(1, "Sub", REG)
    assert parse_wakeup(first.deliveries[0].message).phase is None  # out of context
    assert "Sub" not in wakeups(h.post(2, "T.A"))
    switch = h.post(2, "Psyclone.Context:R.A")
    assert [d.message.sender for d in switch.deliveries] == ["ContextsAndPhases"]  # OA-REG-15
    phase = parse_wakeup(switch.deliveries[0].message).phase
    assert phase is not None and (phase.name, phase.context) == ("PA", "R.A")
    assert "Sub" in wakeups(h.post(2, "T.A"))


def test_without_the_extension_other_contexts_never_fire() -> None:
    h = Harness()
    h.bind(1, "Sub")
    h.subscribe(1, "Sub", REG)
    assert not h.post(2, "Psyclone.Context:R.A").deliveries  # OA-REG-10
    assert "Sub" not in wakeups(h.post(2, "T.A"))


def test_current_phase_answers_the_phase_in_force() -> None:
    h = Harness(extensions=CTX)
    h.bind(1, "Sub")
    h.subscribe(1, "Sub", REG)
    ask = "Psyclone.Module.Request.CurrentPhase"
    assert h.reply(1, ask, to="Psyclone", sender="Sub").content == ""  # OA-SESS-13: none
    h.post(2, "Psyclone.Context:R.A")
    answer = h.reply(1, ask, to="Psyclone", sender="Sub")
    assert 'context="R.A"' in answer.content and "PA" in answer.content
