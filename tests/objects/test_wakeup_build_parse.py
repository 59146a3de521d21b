"""AIR.Instruct.Wakeup (spec 8.7) and phase updates (spec 8.8): building and reading."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st
from objects_helpers import content_schema, schema_errors
from wakeup_frames import (
    PSYCLONE_CC_WAKEUP,
    PSYCLONE_PHASE_UPDATE,
    PSYCLONE_RETRIEVED_WAKEUP,
    PSYCLONE_TRIGGER_WAKEUP,
)

from openair.protocol.codec import decode_message, encode_message
from openair.protocol.content import Phase, RetrieveSpec, Trigger
from openair.protocol.errors import ContentInvalidError
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.wakeup import WAKEUP_TYPE, Wakeup, build_wakeup, parse_wakeup
from openair.protocol.xmlsafe import local_name, parse_fragment

STORED = Message(
    type="Test.Ping.A",
    sender="Poster",
    to="WB1",
    stored="WB1",
    priority=2.0,
    posted=AirTime(sec=1795328371, msec=396),
    received=AirTime(sec=1795328371, msec=444),
    wbid=17,
    content="hello ping",
)
READER_PHASE = Phase(triggers=(Trigger(pattern="Test.Ping.*", whiteboard="WB1"),))


def wire(content: str) -> Message:
    """A wakeup message carrying `content` as XML."""
    return Message(
        type=WAKEUP_TYPE, sender="WB1", to="M", content=content, content_is_xml=True, language="xml"
    )


# --- Psyclone's own wakeups (verbatim, wakeup_frames.py) ------------------------------------


def test_reads_psyclone_trigger_wakeup() -> None:
    msg = decode_message(PSYCLONE_TRIGGER_WAKEUP.encode())
    wakeup = parse_wakeup(msg)
    assert wakeup.trigger is not None
    assert (wakeup.trigger.type, wakeup.trigger.sender, wakeup.trigger.content) == (
        "Test.Ping.A",
        "Poster",
        "hello ping",
    )
    assert wakeup.trigger.stored == "WB1"
    assert wakeup.trigger.netprotocol == "Message"
    assert wakeup.trigger.received == AirTime(sec=1795328371, msec=444)
    assert wakeup.retrieved == ()
    assert wakeup.phase == READER_PHASE
    assert wakeup.lasttrigger == "Test.Ping.*"


def test_reads_psyclone_phase_update() -> None:
    wakeup = parse_wakeup(decode_message(PSYCLONE_PHASE_UPDATE.encode()))
    assert wakeup == Wakeup(trigger=None, phase=READER_PHASE, lasttrigger="")


def test_reads_psyclone_wakeup_with_retrieved_messages() -> None:
    wakeup = parse_wakeup(decode_message(PSYCLONE_RETRIEVED_WAKEUP.encode()))
    assert wakeup.trigger is not None and wakeup.trigger.type == "TR.Go"
    assert [(m.type, m.wbid) for m in wakeup.retrieved] == [("TR.Data.3", 3), ("TR.Data.2", 2)]
    assert wakeup.phase == Phase(
        name="Default",
        triggers=(Trigger(pattern="TR.Go", whiteboard="WB1"),),
        retrieves=(RetrieveSpec(whiteboard="WB1", pattern="TR.Data.*", latest=2),),
        priority=0.0,
    )
    assert wakeup.lasttrigger == "TR.Go"


def test_reads_psyclone_cc_wakeup() -> None:
    wakeup = parse_wakeup(decode_message(PSYCLONE_CC_WAKEUP.encode()))
    assert wakeup.trigger is not None
    assert wakeup.trigger.cc == "Reader" and wakeup.trigger.comment == "CC'ed to Reader"
    assert wakeup.lasttrigger == ""  # OA-WAKE-4: due only to cc


def test_psyclone_echoed_patterns_this_kit_refuses_are_still_read() -> None:
    # Psyclone accepts and echoes `**` (psyclone-wire/09-wildcards.txt); a module must not
    # refuse its wakeups because of that.
    phase = (
        '<phase name="Default Phase" module="M" context="Psyclone.System.Ready" '
        'lasttrigger="**"><triggers><trigger after="0" from="any" type="**"/></triggers>'
        "</phase>"
    )
    content = f'<objectdictionary><object name="PhaseSpec">{phase}</object></objectdictionary>'
    wakeup = parse_wakeup(wire(content))
    assert wakeup.phase == Phase(triggers=(Trigger(pattern="**"),))
    assert wakeup.lasttrigger == "**"


# --- building (spec 8.7, 8.8) ---------------------------------------------------------------


def test_build_wakeup_follows_oa_wake_1() -> None:
    retrieved = [
        STORED,
        Message(
            type="Test.Ping.0", sender="P", stored="WB1", wbid=16, posted=AirTime(sec=1, msec=0)
        ),
    ]
    msg = build_wakeup(
        stored=STORED,
        whiteboard="WB1",
        module="Reader",
        retrieved=retrieved,
        phase=READER_PHASE,
        lasttrigger="Test.Ping.*",
    )
    assert (msg.type, msg.sender, msg.to, msg.stored) == (WAKEUP_TYPE, "WB1", "Reader", "WB1")
    assert msg.content_is_xml and msg.language == "xml"
    (root,) = parse_fragment(msg.content)
    assert local_name(root) == "objectdictionary"
    assert [o.get("name") for o in root] == ["TriggerMessage", "RetrievedMessages", "PhaseSpec"]
    phase = root[2][0]
    assert {k: phase.get(k) for k in ("name", "module", "context", "lasttrigger")} == {
        "name": "Default Phase",
        "module": "Reader",
        "context": "Psyclone.System.Ready",
        "lasttrigger": "Test.Ping.*",
    }
    assert [dict(t.attrib) for t in phase[0]] == [
        {"after": "0", "from": "WB1", "type": "Test.Ping.*"}
    ]
    assert parse_wakeup(msg) == Wakeup(
        trigger=STORED, retrieved=tuple(retrieved), phase=READER_PHASE, lasttrigger="Test.Ping.*"
    )


def test_built_wakeup_is_a_canonical_message() -> None:
    msg = build_wakeup(
        stored=STORED,
        whiteboard="WB1",
        module="Reader",
        phase=READER_PHASE,
        lasttrigger="Test.Ping.*",
    )
    stamped = replace(msg, posted=AirTime(sec=9))  # the sender stamps postedTime (OA-TIME-2)
    xml = encode_message(stamped).decode()
    assert schema_errors(content_schema(), xml, "message") == ""
    assert parse_wakeup(decode_message(xml.encode())) == parse_wakeup(msg)


def test_wakeup_without_registration_has_an_empty_default_phase() -> None:
    # OA-WAKE-4: a module woken by cc alone, without a registration.
    msg = build_wakeup(stored=STORED, whiteboard="WB1", module="CcOnly")
    wakeup = parse_wakeup(msg)
    assert wakeup.phase == Phase() and wakeup.lasttrigger == "" and wakeup.retrieved == ()


def test_phase_update_has_only_phase_spec() -> None:
    # spec 8.8, OA-WAKE-9: from ContextsAndPhases, only PhaseSpec, stored empty as Psyclone's.
    msg = build_wakeup(
        stored=None, whiteboard="ContextsAndPhases", module="Reader", phase=READER_PHASE
    )
    assert (msg.sender, msg.to, msg.stored) == ("ContextsAndPhases", "Reader", "")
    (root,) = parse_fragment(msg.content)
    assert [o.get("name") for o in root] == ["PhaseSpec"]
    assert parse_wakeup(msg) == Wakeup(trigger=None, phase=READER_PHASE)


def test_phase_update_out_of_context_has_no_phase_spec() -> None:
    # OA-REG-15: no PhaseSpec object when no phase is in force.
    msg = build_wakeup(stored=None, whiteboard="ContextsAndPhases", module="Reader")
    assert msg.content == "<objectdictionary/>"
    assert parse_wakeup(msg) == Wakeup(trigger=None, phase=None)


@given(
    n_retrieved=st.integers(0, 3),
    lasttrigger=st.sampled_from(["", "Test.Ping.*", "*"]),
    has_phase=st.booleans(),
    module=st.sampled_from(["Reader", "M-1", "ü"]),
)
def test_built_wakeups_parse_back_and_validate(
    n_retrieved: int, lasttrigger: str, has_phase: bool, module: str
) -> None:
    retrieved = [
        Message(type=f"T.{i}", stored="WB1", wbid=i, posted=AirTime(sec=i))
        for i in range(n_retrieved)
    ]
    phase = READER_PHASE if has_phase else None
    msg = build_wakeup(
        stored=STORED,
        whiteboard="WB1",
        module=module,
        retrieved=retrieved,
        phase=phase,
        lasttrigger=lasttrigger,
    )
    assert parse_wakeup(msg) == Wakeup(
        trigger=STORED, retrieved=tuple(retrieved), phase=phase or Phase(), lasttrigger=lasttrigger
    )
    assert schema_errors(content_schema(), msg.content, "objectdictionary") == ""


# --- reading leniently, refusing clearly ----------------------------------------------------


def test_objects_in_any_order_unknown_objects_and_empty_content() -> None:
    trigger = '<message><type>A</type><content language="">x</content></message>'
    content = (
        f'<objectdictionary><object name="Extra"><time sec="1" msec="0"/></object>'
        f'<object name="PhaseSpec"/><object name="TriggerMessage">{trigger}</object>'
        "</objectdictionary>"
    )
    wakeup = parse_wakeup(wire(content))
    assert wakeup.trigger is not None and wakeup.trigger.type == "A"
    assert wakeup.phase is None and wakeup.retrieved == ()
    assert parse_wakeup(wire("")) == Wakeup(trigger=None)
    assert parse_wakeup(wire("<OBJECTDICTIONARY/>")) == Wakeup(trigger=None)


@pytest.mark.parametrize(
    "content",
    [
        "hello",
        "<objectcollection/>",
        "<objectdictionary/><objectdictionary/>",
        "<objectdictionary><entry name='TriggerMessage'/></objectdictionary>",
        "<objectdictionary><object><message><type>A</type></message></object></objectdictionary>",
        "<objectdictionary><object name='TriggerMessage'><reference id='x'/></object>"
        "</objectdictionary>",
        "<objectdictionary><object name='TriggerMessage'><message><id>x</id></message></object>"
        "</objectdictionary>",
        "<objectdictionary><object name='TriggerMessage'><message><type>A</type></message>"
        "<message><type>B</type></message></object></objectdictionary>",
        "<objectdictionary><object name='TriggerMessage'><message><type>A</type></message>"
        "</object><object name='TriggerMessage'><message><type>A</type></message></object>"
        "</objectdictionary>",
        "<objectdictionary><object name='RetrievedMessages'><collection/></object>"
        "</objectdictionary>",
        "<objectdictionary><object name='RetrievedMessages'><objectcollection><object><time "
        "sec='1'/></object></objectcollection></object></objectdictionary>",
        "<objectdictionary><object name='PhaseSpec'><module/></object></objectdictionary>",
        "<objectdictionary><object name='PhaseSpec'><phase><triggers><trigger/></triggers>"
        "</phase></object></objectdictionary>",
        "<objectdictionary><object name='PhaseSpec'><phase><triggers><trigger type='A' "
        "after='soon'/></triggers></phase></object></objectdictionary>",
        "<objectdictionary>",
    ],
)
def test_unreadable_wakeups_are_content_invalid(content: str) -> None:
    with pytest.raises(ContentInvalidError):
        parse_wakeup(wire(content))


def test_only_wakeups_are_parsed() -> None:
    with pytest.raises(ContentInvalidError):
        parse_wakeup(Message(type="Test.Ping.A", content="<objectdictionary/>"))
