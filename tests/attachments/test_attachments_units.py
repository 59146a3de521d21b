"""Units of issue #21: form 5 registrations, alarm triggers, wakeup budgets, payload search."""

from __future__ import annotations

import pytest

from openair.protocol.content import Trigger
from openair.protocol.errors import RegistrationInvalidError
from openair.protocol.message import Message
from openair.protocol.registration import encode_registration, parse_registration
from openair.protocol.wakeup import fit_attachments


def test_bare_stream_elements_are_a_registration() -> None:
    reg = parse_registration("M", '<stream name="Eyes" source="Stream1"/>')  # OA-REG-16
    (phase,) = reg.phases
    assert [(s.kind, s.alias, s.source) for s in phase.streams] == [("stream", "Eyes", "Stream1")]
    assert phase.triggers == () and phase.name == "Default Phase"
    content = (
        '<streams><inputstream alias="In" source="S.*"/></streams>'
        '<triggers><trigger from="WB1" type="T.Go"/></triggers>'
    )
    (phase,) = parse_registration("M", content).phases
    assert [t.pattern for t in phase.triggers] == ["T.Go"]
    assert [s.source for s in phase.streams] == ["S.*"]


def test_stream_elements_beside_anything_else_are_refused() -> None:
    with pytest.raises(RegistrationInvalidError):  # OA-REG-8: not one of the five forms
        parse_registration("M", '<stream name="E" source="S"/><module name="M"/>')


@pytest.mark.parametrize("value", ["0.5", " 0 ", "6.999", "2"])
def test_maxpriority_is_read_and_written(value: str) -> None:
    content = f'<triggers><trigger type="A.*" maxpriority="{value}"/></triggers>'
    (trigger,) = parse_registration("M", content).phases[0].triggers
    assert trigger.max_priority == float(value)  # OA-TRIG-5
    again = parse_registration("M", encode_registration(parse_registration("M", content)))
    assert again.phases[0].triggers == (trigger,)


@pytest.mark.parametrize("value", ["7", "-1", "x", "", "1e0"])
def test_maxpriority_out_of_range_is_refused(value: str) -> None:
    content = f'<triggers><trigger type="A.*" maxpriority="{value}"/></triggers>'
    with pytest.raises(RegistrationInvalidError):
        parse_registration("M", content)


def test_a_trigger_without_maxpriority_has_none() -> None:
    (trigger,) = (
        parse_registration("M", '<triggers><trigger type="A"/></triggers>').phases[0].triggers
    )
    assert trigger == Trigger(pattern="A")


def _copy(n: int, size: int) -> Message:
    return Message(type="A", id=str(n), binary=(b"x" * size,) if size else ())


def test_fit_attachments_leaves_retrieved_messages_out_from_the_end() -> None:
    trigger = _copy(0, 4)
    retrieved = [_copy(1, 3), _copy(2, 0), _copy(3, 3), _copy(4, 1)]
    kept, omitted = fit_attachments(trigger, retrieved, 9)  # OA-WAKE-11: 4 + 3 + 0 fit, +3 not
    assert [m.id for m in kept] == ["1", "2"] and omitted == 2
    kept, omitted = fit_attachments(trigger, retrieved, 11)
    assert [m.id for m in kept] == ["1", "2", "3", "4"] and omitted == 0
    kept, omitted = fit_attachments(trigger, retrieved, 4)
    assert [m.id for m in kept] == [] and omitted == 4
