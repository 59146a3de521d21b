"""Router whiteboard commands: posts, AIR.Subscribe, triggers, cc, wakeups, retrieve (7–10)."""

from __future__ import annotations

import pytest
from router_harness import MS, Harness, wakeups

from openair.protocol.message import Message
from openair.protocol.objects import parse_message_collection
from openair.server.core.config import ServerLimits, parse_config
from openair.server.core.store import MemoryStore

SUB_PING = '<triggers><trigger from="WB1" type="Test.Ping.*"/></triggers>'


def _retrieve(
    h: Harness, xml: str, *, type_: str = "AIR.Retrieve", to: str = "AIRCentral"
) -> Message:
    return h.reply(1, type_, to=to, sender="Reader", content=xml, content_is_xml=True)


def test_post_is_stored_then_acknowledged() -> None:
    h = Harness()
    msg = Message(type="Test.Ping.A", sender="Poster", to="WB1", content="hello", priority=3.0)
    outcome = h.send(3, msg)
    (ack,) = outcome.replies
    assert (ack.type, ack.sender, ack.isresponse) == ("RECEIVE_ACCEPT", "WB1", msg.id)  # OA-WB-3
    board = h.router.whiteboard("WB1")
    assert board is not None
    (stored,) = board.newest_first()
    assert stored.id == msg.id and stored.stored == "WB1" and stored.wbid == 1  # OA-WB-4
    assert stored.received is not None and stored.received.ms == h.now // MS  # OA-TIME-3


@pytest.mark.parametrize(
    "type_", ["Test.*", "Test..A", ".A", "A.", "A B", "", "x" * 256, ".".join("a" * 33)]
)
def test_invalid_post_type_is_refused(type_: str) -> None:
    h = Harness()
    answer = h.reply(1, type_, to="WB1", sender="P")
    assert answer.type == "RECEIVE_ERROR" and answer.content.startswith("TYPE_INVALID")  # OA-TYPE-3
    board = h.router.whiteboard("WB1")
    assert board is not None and len(board) == 0


def test_type_limits_follow_the_server_limits() -> None:
    h = Harness(limits=ServerLimits(max_type_bytes=8, max_type_segments=2))
    assert h.reply(1, "A.B", to="WB1").type == "RECEIVE_ACCEPT"
    assert h.reply(1, "A.B.C", to="WB1").type == "RECEIVE_ERROR"  # OA-TYPE-4
    assert h.reply(1, "ABCDEFGHI", to="WB1").type == "RECEIVE_ERROR"


def test_store_failure_is_not_acknowledged() -> None:
    class Failing(MemoryStore):
        fail = False

        def append(self, whiteboard: str, msg: Message) -> None:
            if self.fail:
                raise OSError("disk full")
            super().append(whiteboard, msg)

    store = Failing()
    h = Harness(store=store)
    h.bind(1, "Reader")
    h.subscribe(1, "Reader", SUB_PING)
    store.fail = True
    outcome = h.post(2, "Test.Ping.A")
    (answer,) = outcome.replies
    assert answer.type == "RECEIVE_ERROR" and answer.content.startswith("STORE_FAILED")  # OA-WB-3
    assert outcome.deliveries == ()  # OA-ERR-5: nothing decided for a post that is not stored


def test_noreply_post_gets_no_reply_but_is_processed() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.subscribe(1, "Reader", SUB_PING)
    outcome = h.post(2, "Test.Ping.A", noreply=True)
    assert outcome.replies == () and "Reader" in wakeups(outcome)  # OA-WB-8, OA-MSG-15
    assert h.post(2, "Bad*", noreply=True).replies == ()  # failures are not reported either
    legacy = Harness(extensions=frozenset())
    assert len(legacy.post(2, "Test.Ping.A", noreply=True).replies) == 1  # not advertised


def test_wakeup_content_and_delivery_fields() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.subscribe(
        1, "Reader", '<triggers><trigger from="wb1" type="Test.Ping.*" after="250"/></triggers>'
    )
    outcome = h.post(3, "Test.Ping.A", content="hello ping", priority=3.5)
    (delivery,) = outcome.deliveries
    assert delivery.module == "Reader"
    assert delivery.due_ns == h.now + 250 * MS  # OA-TRIG-3
    assert (delivery.priority, delivery.wb_priority) == (3.5, 1.0)  # OA-PRIO-1/2
    msg = delivery.message
    assert (msg.type, msg.sender, msg.to, msg.stored) == (
        "AIR.Instruct.Wakeup",
        "WB1",
        "Reader",
        "WB1",
    )
    wakeup = wakeups(outcome)["Reader"]
    assert wakeup.trigger is not None and wakeup.trigger.content == "hello ping"  # OA-WAKE-2
    assert wakeup.trigger.wbid == 1 and wakeup.trigger.stored == "WB1"
    assert wakeup.lasttrigger == "Test.Ping.*" and wakeup.retrieved == ()  # OA-WAKE-4


def test_subscribe_replies_and_sends_a_phase_update() -> None:
    h = Harness()
    h.bind(1, "Reader")
    outcome = h.subscribe(1, "Reader", SUB_PING, to="WB2")
    assert [(r.type, r.sender) for r in outcome.replies] == [("RECEIVE_ACCEPT", "WB2")]  # OA-REG-7
    (update,) = outcome.deliveries  # OA-WAKE-9
    assert update.message.sender == "ContextsAndPhases" and update.module == "Reader"
    assert "TriggerMessage" not in update.message.content
    # Sent to WB2, the trigger still names WB1 (OA-REG-1: the addressee does not limit it).
    assert "Reader" in wakeups(h.post(3, "Test.Ping.A"))


def test_subscribe_replaces_the_whole_registration() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.subscribe(1, "Reader", SUB_PING)
    h.subscribe(1, "Reader", '<triggers><trigger type="Other.*"/></triggers>')  # OA-REG-1
    assert wakeups(h.post(3, "Test.Ping.A")) == {}
    assert "Reader" in wakeups(h.post(3, "Other.X"))
    h.subscribe(1, "Reader", "<triggers/>")  # OA-REG-11: an empty registration is valid
    assert wakeups(h.post(3, "Other.X")) == {}


@pytest.mark.parametrize(
    ("content", "condition"),
    [
        ("", "REGISTRATION_INVALID"),
        ("<garbage/>", "REGISTRATION_INVALID"),
        ("<triggers><trigger/></triggers>", "REGISTRATION_INVALID"),
        ('<triggers><trigger type="A" after="-1"/></triggers>', "REGISTRATION_INVALID"),
        ('<triggers><trigger type="A**"/></triggers>', "PATTERN_INVALID"),
        ("<triggers>" + '<trigger type="A"/>' * 3 + "</triggers>", "LIMIT_EXCEEDED"),
    ],
)
def test_invalid_subscribe_keeps_the_old_registration(content: str, condition: str) -> None:
    h = Harness(limits=ServerLimits(max_triggers=2))
    h.bind(1, "Reader")
    h.subscribe(1, "Reader", SUB_PING)
    (answer,) = h.subscribe(1, "Reader", content).replies
    assert answer.type == "RECEIVE_ERROR" and answer.content.startswith(condition)  # OA-REG-8
    assert "Reader" in wakeups(h.post(3, "Test.Ping.A"))


def test_subscribe_without_from_is_refused() -> None:
    (answer,) = Harness().subscribe(1, "", SUB_PING).replies
    assert answer.content.startswith("REGISTRATION_INVALID")  # OA-REG-8


def test_trigger_from_is_case_insensitive_and_any() -> None:
    h = Harness()
    for i, source in enumerate(["WB1", "wb1", "any", "*", "", None, "WB*", "NoSuchWB"]):
        name = f"M{i}"
        attr = "" if source is None else f' from="{source}"'
        h.bind(i + 10, name)
        h.subscribe(i + 10, name, f'<triggers><trigger{attr} type="Test.*"/></triggers>')
    to_wb1 = sorted(wakeups(h.post(3, "Test.A", to="WB1")))
    to_wb2 = sorted(wakeups(h.post(3, "Test.A", to="WB2")))
    assert to_wb1 == ["M0", "M1", "M2", "M3", "M4", "M5"]  # OA-TRIG-2
    assert to_wb2 == ["M2", "M3", "M4", "M5"]


def test_self_triggering() -> None:
    h = Harness()
    h.bind(1, "Self")
    h.subscribe(1, "Self", '<triggers><trigger type="Test.*"/></triggers>')
    assert wakeups(h.post(1, "Test.A", sender="Self")) == {}  # OA-TRIG-4
    assert "Self" in wakeups(h.post(1, "Test.A", sender="self"))  # exact comparison
    h.subscribe(
        1, "Self", '<module name="Self" allowselftriggering="YES"><trigger type="Test.*"/></module>'
    )
    assert "Self" in wakeups(h.post(1, "Test.A", sender="Self"))  # OA-REG-6


def test_one_wakeup_with_the_smallest_after() -> None:
    h = Harness()
    h.bind(1, "Reader")
    xml = (
        '<triggers><trigger type="Test.*" after="500"/><trigger type="Test.A" after="100"/>'
        '<trigger type="*" after="100"/></triggers>'
    )
    h.subscribe(1, "Reader", xml)
    outcome = h.post(3, "Test.A", cc="Reader")
    (delivery,) = outcome.deliveries  # OA-WAKE-5
    assert delivery.due_ns == h.now + 100 * MS  # OA-WAKE-6: smallest after ...
    assert wakeups(outcome)["Reader"].lasttrigger == "Test.A"  # ... first on a tie


def test_cc_wakes_bound_modules_only() -> None:
    h = Harness()
    h.bind(1, "CcA")  # bound, never subscribed (OA-CC-2)
    h.bind(2, "CcB")
    h.subscribe(2, "CcB", '<triggers><trigger type="Other.*"/></triggers>')
    outcome = h.post(3, "Test.Cc", cc=" CcA ; CcB;;cca;Nobody")
    found = wakeups(outcome)
    assert sorted(found) == ["CcA", "CcB"]  # OA-CC-1, OA-CC-3
    assert all(w.lasttrigger == "" for w in found.values())  # OA-WAKE-4
    assert all(d.due_ns == h.now for d in outcome.deliveries)  # OA-WAKE-6: no delay
    assert outcome.replies[0].type == "RECEIVE_ACCEPT"
    assert found["CcA"].phase is not None and found["CcA"].phase.triggers == ()


def test_cc_wakes_the_poster_and_trigger_wins_lasttrigger() -> None:
    h = Harness()
    h.bind(1, "Self")
    h.subscribe(1, "Self", '<triggers><trigger type="Test.*" after="300"/></triggers>')
    found = wakeups(h.post(1, "Test.A", sender="Self", cc="Self"))
    assert found["Self"].lasttrigger == ""  # OA-CC-4: the trigger does not fire for the poster
    h.bind(2, "Both")
    h.subscribe(2, "Both", '<triggers><trigger type="Test.*" after="300"/></triggers>')
    outcome = h.post(3, "Test.A", cc="Both")
    assert wakeups(outcome)["Both"].lasttrigger == "Test.*"  # OA-WAKE-6
    assert outcome.deliveries[0].due_ns == h.now + 300 * MS


def test_unbound_registrations_do_not_wake() -> None:
    h = Harness()
    h.subscribe(1, "Ghost", SUB_PING)  # OA-SESS-16: allowed without BIND
    assert wakeups(h.post(3, "Test.Ping.A")) == {}
    h.bind(1, "Ghost")
    assert "Ghost" in wakeups(h.post(3, "Test.Ping.A"))


def test_registration_retrieves_are_evaluated_at_decision_time() -> None:
    h = Harness()
    h.bind(1, "Reader")
    xml = (
        '<module name="Reader"><triggers from="WB1"><trigger type="Test.Ping.*"/></triggers>'
        '<retrieves><retrieve type="Test.*"><latest>2</latest></retrieve>'
        '<retrieve from="WB2" type="*"/><retrieve from="NoSuchWB" type="*"/></retrieves></module>'
    )
    h.subscribe(1, "Reader", xml)
    h.post(3, "Test.Data.1")
    h.post(3, "Other.X", to="WB2")
    wakeup = wakeups(h.post(3, "Test.Ping.A"))["Reader"]
    # OA-WAKE-7: includes the trigger itself; no `from` reads WB1; WB2 next; NoSuchWB adds nothing.
    assert [m.type for m in wakeup.retrieved] == ["Test.Ping.A", "Test.Data.1", "Other.X"]


def test_bare_form_retrieves_apply() -> None:
    h = Harness()
    h.bind(1, "Reader")
    retrieves = '<retrieve from="WB1" type="Test.Data.*"><latest>2</latest></retrieve>'
    xml = f"{SUB_PING}<retrieves>{retrieves}</retrieves>"
    h.subscribe(1, "Reader", xml)
    for i in range(3):
        h.post(3, f"Test.Data.{i}")
    wakeup = wakeups(h.post(3, "Test.Ping.A"))["Reader"]
    assert [m.type for m in wakeup.retrieved] == ["Test.Data.2", "Test.Data.1"]  # OA-REG-2


def test_other_contexts_do_not_fire() -> None:
    h = Harness()
    h.bind(1, "M")
    xml = (
        '<module name="M"><context name="Some.Other"><phase id="P"><triggers>'
        '<trigger type="Test.*"/></triggers></phase></context></module>'
    )
    assert h.subscribe(1, "M", xml).replies[0].type == "RECEIVE_ACCEPT"  # OA-REG-10
    assert wakeups(h.post(3, "Test.A")) == {}


def test_config_registration_until_subscribe_and_after_loss() -> None:
    spec = (
        b'<psySpec name="S" version="1.2"><whiteboard name="WB1"/>'
        b'<module name="M"><trigger from="WB1" type="Cfg.*"/></module></psySpec>'
    )
    h = Harness(parse_config(spec, source="s.xml"))
    assert wakeups(h.post(3, "Cfg.A")) == {}  # not bound yet
    h.bind(1, "M")
    assert "M" in wakeups(h.post(3, "Cfg.A"))  # OA-CONF-5
    h.subscribe(1, "M", '<triggers><trigger type="Own.*"/></triggers>')
    assert wakeups(h.post(3, "Cfg.A")) == {}
    h.close(1)
    h.bind(2, "M")
    assert "M" in wakeups(h.post(3, "Cfg.A"))  # the configured registration again


def test_whiteboard_priority_on_deliveries() -> None:
    spec = b'<psySpec name="S" version="1.2"><whiteboard name="Fast" priority="0.5"/></psySpec>'
    h = Harness(parse_config(spec, source="s.xml"))
    h.bind(1, "M")
    h.subscribe(1, "M", '<triggers><trigger type="*"/></triggers>')
    (delivery,) = h.post(3, "A", to="Fast").deliveries
    assert delivery.wb_priority == 0.5 and delivery.priority == 2.0  # OA-PRIO-2, OA-PRIO-3


# --- retrieve --------------------------------------------------------------------------------


def _posted(h: Harness) -> None:
    for i in range(1, 4):
        h.post(3, f"Ret.A.{i}", content=f"c{i}")
    h.post(3, "Ret.B.1", to="WB2")


def test_retrieve_success() -> None:
    h = Harness()
    _posted(h)
    answer = _retrieve(h, '<retrieve from="WB1" type="Ret.*"><latest>2</latest></retrieve>')
    assert answer.type == "AIR.Retrieve.Success" and answer.sender == "AIRCentral"  # OA-RET-7
    assert [m.type for m in parse_message_collection(answer.content)] == ["Ret.A.3", "Ret.A.2"]
    # No `from`: the addressee (OA-RET-2).
    direct = _retrieve(h, '<retrieve type="Ret.*"/>', to="WB2")
    assert [m.type for m in parse_message_collection(direct.content)] == ["Ret.B.1"]
    empty = _retrieve(h, '<retrieve type="Ret.*"/>')
    assert parse_message_collection(empty.content) == ()


def test_retrieves_concatenate() -> None:
    h = Harness()
    _posted(h)
    xml = (
        '<retrieves><retrieve from="WB1" type="Ret.A.1"/>'
        '<retrieve from="WB2" type="*"/></retrieves>'
    )
    answer = _retrieve(h, xml, type_="AIR.Retrieves")
    assert answer.type == "AIR.Retrieves.Success"  # OA-RET-12
    assert [m.type for m in parse_message_collection(answer.content)] == ["Ret.A.1", "Ret.B.1"]


def test_retrieve_as_text_content() -> None:
    h = Harness()
    _posted(h)
    answer = h.reply(
        1,
        "AIR.Retrieve",
        to="AIRCentral",
        content='<retrieve from="WB1" type="Ret.*"/>',
        language="",
    )
    assert answer.type == "AIR.Retrieve.Success"  # OA-RET-14
    assert len(parse_message_collection(answer.content)) == 1


@pytest.mark.parametrize(
    ("type_", "xml", "expected"),
    [
        ("AIR.Retrieve", '<retrieve from="wb1" type="Ret.*"/>', "WHITEBOARD_UNKNOWN: wb1"),
        ("AIR.Retrieve", '<retrieve from="NoSuchWB"/>', "WHITEBOARD_UNKNOWN: NoSuchWB"),
        ("AIR.Retrieve", "", "RETRIEVE_INVALID"),
        ("AIR.Retrieve", "<garbage/>", "RETRIEVE_INVALID"),
        ("AIR.Retrieve", '<retrieve from="WB1"><latest>x</latest></retrieve>', "RETRIEVE_INVALID"),
        ("AIR.Retrieve", '<retrieve latest="2"><latest>3</latest></retrieve>', "RETRIEVE_INVALID"),
        ("AIR.Retrieve", '<retrieve during="x"/>', "RETRIEVE_INVALID"),
        ("AIR.Retrieve", '<retrieve type="A**"/>', "PATTERN_INVALID"),
        ("AIR.Retrieve", "<retrieves><retrieve/></retrieves>", "RETRIEVE_INVALID"),
        ("AIR.Retrieves", "<retrieve/>", "RETRIEVE_INVALID"),
        (
            "AIR.Retrieves",
            '<retrieves><retrieve/><retrieve from="X"/></retrieves>',
            "WHITEBOARD_UNKNOWN",
        ),
    ],
)
def test_retrieve_failures(type_: str, xml: str, expected: str) -> None:
    answer = _retrieve(Harness(), xml, type_=type_)
    assert answer.type == f"{type_}.Failed"  # OA-RET-10, OA-RET-11, OA-RET-12
    assert answer.content.startswith(expected)


def test_retrieve_reply_within_max_frame_xml() -> None:
    h = Harness(limits=ServerLimits(max_frame_xml=4096))
    for i in range(40):
        h.post(3, "Big.A", content="x" * 100 + str(i))
    answer = _retrieve(h, '<retrieve from="WB1"><latest>0</latest></retrieve>')
    assert answer.type == "AIR.Retrieve.Failed" and answer.content.startswith("LIMIT_EXCEEDED")
    assert _retrieve(h, '<retrieve from="WB1"/>').type == "AIR.Retrieve.Success"  # OA-RET-15


def test_whiteboard_commands_are_not_stored() -> None:
    h = Harness()
    h.subscribe(1, "Reader", SUB_PING, to="WB1")
    _retrieve(h, '<retrieve type="*"/>', to="WB1")
    h.reply(1, "PING", to="WB1")
    board = h.router.whiteboard("WB1")
    assert board is not None and len(board) == 0  # OA-WB-11
