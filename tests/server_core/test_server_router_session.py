"""Router session commands: BIND, callbacks, takeover, loss, RESOLVE and the components (spec 6)."""

from __future__ import annotations

from typing import Any

import pytest
from router_harness import T0, Harness, wakeups

from openair.protocol.content import RetrieveSpec
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message, Slot
from openair.protocol.objects import (
    parse_capabilities,
    parse_dictionary,
    parse_tcplocation,
    parse_time,
)
from openair.protocol.wakeup import parse_wakeup
from openair.server.core.config import ServerLimits, parse_config

LOST_WATCH = '<triggers><trigger from="AIRCentral" type="Psyclone.Module.*"/></triggers>'


def _aircentral_types(h: Harness) -> list[str]:
    board = h.router.whiteboard("AIRCentral")
    assert board is not None
    return [m.type for m in board.retrieve(RetrieveSpec(latest=0), now_ns=h.now)]


def test_bind_accepts_with_a_port() -> None:
    h = Harness()
    request = Message(type="BIND", sender="Reader", to="CNS")
    outcome = h.send(1, request)
    (accept,) = outcome.replies
    assert accept.type == "BIND_ACCEPT" and accept.content == "10114"  # OA-SESS-3
    assert (accept.isresponse, accept.sender, accept.to) == (request.id, "CNS", "Reader")
    assert accept.posted is not None  # OA-SESS-32
    assert h.reply(2, "BIND", sender="Other").content == "10115"
    info = h.router.module("Reader")
    assert info is not None and info.conn == 1 and info.port == 10114
    assert info.extensions == frozenset()  # legacy: declared nothing (OA-SESS-19)


def test_bind_uses_the_allocator() -> None:
    h = Harness(port_allocator=lambda wanted: 40000 + wanted)
    assert h.reply(1, "BIND", sender="Reader").content == "40000"


def test_bind_requested_port() -> None:
    h = Harness()
    h.router.connection_opened(1, address="10.0.0.1")
    h.router.connection_opened(2, address="10.0.0.1")
    h.router.connection_opened(3, address="10.0.0.2")
    xml = '<tcplocation port="10555"/>'
    assert h.reply(1, "BIND", sender="A", content=xml, content_is_xml=True).content == "10555"
    clash = h.reply(2, "BIND", sender="B", content=xml, content_is_xml=True)
    assert clash.type == "BIND_ERROR" and clash.content.startswith("BIND_REFUSED: ")  # OA-SESS-4
    other_host = h.reply(3, "BIND", sender="C", content=xml, content_is_xml=True)
    assert other_host.content == "10555"
    for bad in ('<tcplocation port="0"/>', '<tcplocation port="70000"/>', "<nonsense/>"):
        refused = h.reply(2, "BIND", sender="D", content=bad, content_is_xml=True)
        assert refused.type == "BIND_ERROR", bad


def test_bind_nolisten() -> None:
    h = Harness()
    assert h.reply(1, "BIND_NOLISTEN", sender="Nat").content == "-1"  # OA-SESS-5
    info = h.router.module("Nat")
    assert info is not None and info.port == -1


@pytest.mark.parametrize("name", ["", "a b", "a;b", "tab\there", "x" * 256, "WB1", "CNS", "Config"])
def test_bind_refuses_bad_names(name: str) -> None:
    answer = Harness().reply(1, "BIND", sender=name)
    assert answer.type == "BIND_ERROR" and answer.content.startswith("BIND_REFUSED")  # OA-SESS-30


def test_bind_declares_extensions() -> None:
    h = Harness()
    msg = Message(
        type="BIND",
        sender="Reader",
        to="CNS",
        extras=(Slot(name="extensions", value="pipelining usec bogus auth"),),
    )
    h.send(1, msg)
    info = h.router.module("Reader")
    assert info is not None and info.extensions == frozenset({"pipelining", "usec"})  # OA-EXT-1


def test_callback_connection() -> None:
    h = Harness()
    h.bind(1, "Reader")
    rnn = Message(type="RECEIVE_NAME_NOTIFICATION", sender="Reader")
    outcome = h.send(2, rnn, tag=FrameTag.RECEIVE)
    assert outcome.replies == () and outcome.close_conns == ()  # OA-SESS-7: no reply
    info = h.router.module("Reader")
    assert info is not None and info.callback == 2
    newer = h.send(3, rnn, tag=FrameTag.RECEIVE)
    assert newer.close_conns == (2,)  # the newer one replaces the older
    info = h.router.module("Reader")
    assert info is not None and info.callback == 3
    h.close(3)
    info = h.router.module("Reader")
    assert info is not None and info.callback is None


def test_callback_before_bind_is_kept() -> None:
    h = Harness()
    rnn = Message(type="RECEIVE_NAME_NOTIFICATION", sender="Early")
    assert h.send(5, rnn, tag=FrameTag.RECEIVE) == h.send(5, rnn, tag=FrameTag.RECEIVE)
    h.bind(1, "Early")
    info = h.router.module("Early")
    assert info is not None and info.callback == 5


def test_receive_frame_with_another_type_is_refused() -> None:
    h = Harness()
    (answer,) = h.send(2, Message(type="PING", sender="X"), tag=FrameTag.RECEIVE).replies
    assert answer.type == "RECEIVE_ERROR" and answer.content.startswith("MESSAGE_INVALID")
    # ... and outside a Receive frame the notification would need a reply it cannot have.
    assert h.reply(2, "RECEIVE_NAME_NOTIFICATION", sender="X").type == "RECEIVE_ERROR"


def test_receive_frame_with_an_impossible_name_closes() -> None:
    outcome = Harness().send(
        2, Message(type="RECEIVE_NAME_NOTIFICATION", sender="a b"), tag=FrameTag.RECEIVE
    )
    assert outcome.close_this and outcome.replies == ()


def test_takeover_closes_the_old_session_and_posts_restored() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.send(2, Message(type="RECEIVE_NAME_NOTIFICATION", sender="Reader"), tag=FrameTag.RECEIVE)
    h.subscribe(1, "Reader", '<triggers><trigger type="Test.*"/></triggers>')
    h.bind(9, "Watcher")
    h.subscribe(9, "Watcher", LOST_WATCH)
    outcome = h.bind(3, "Reader")
    assert sorted(outcome.close_conns) == [1, 2]  # OA-SESS-6
    assert list(wakeups(outcome)) == ["Watcher"]
    assert _aircentral_types(h)[0] == "Psyclone.Module.Restored.Reader"
    info = h.router.module("Reader")
    assert info is not None and info.conn == 3 and info.callback is None
    # The old connections close: no Lost notice, the registration is kept.
    assert h.close(1).discard_queues == () and h.close(2).deliveries == ()
    assert "Psyclone.Module.Lost.Reader" not in _aircentral_types(h)
    assert "Reader" in wakeups(h.post(7, "Test.A"))


def test_rebind_on_the_same_connection_is_no_takeover() -> None:
    h = Harness()
    h.bind(1, "Reader")
    outcome = h.bind(1, "Reader")
    assert outcome.close_conns == () and outcome.deliveries == ()


def test_closing_the_primary_connection_loses_the_module() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.bind(1, "Second")  # one connection, two names (spec 6.3 notes)
    h.send(2, Message(type="RECEIVE_NAME_NOTIFICATION", sender="Reader"), tag=FrameTag.RECEIVE)
    h.subscribe(1, "Reader", '<triggers><trigger type="Test.*"/></triggers>')
    h.bind(9, "Watcher")
    h.subscribe(9, "Watcher", LOST_WATCH)
    outcome = h.close(1)
    assert outcome.close_conns == (2,)  # OA-SESS-15: its callback is closed
    assert sorted(outcome.discard_queues) == ["Reader", "Second"]
    lost = [parse_wakeup(d.message).trigger for d in outcome.deliveries if d.module == "Watcher"]
    assert sorted(t.type for t in lost if t is not None) == [
        "Psyclone.Module.Lost.Reader",
        "Psyclone.Module.Lost.Second",
    ]
    assert h.router.module("Reader") is None and h.router.registration("Reader") is None
    types = _aircentral_types(h)
    assert "Psyclone.Module.Lost.Reader" in types and "Psyclone.Module.Lost.Second" in types
    assert h.close(2) == h.close(77)  # unknown or already forgotten connections: nothing


def test_lost_notice_comes_from_psyclone() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.close(1)
    board = h.router.whiteboard("AIRCentral")
    assert board is not None
    newest = next(board.newest_first())
    assert (newest.type, newest.sender, newest.to) == (
        "Psyclone.Module.Lost.Reader",
        "Psyclone",
        "AIRCentral",
    )


def test_startup_posts_system_ready() -> None:
    types = _aircentral_types(Harness())  # OA-SESS-31
    assert types == ["Psyclone.Context:Psyclone.System.Ready"]


def test_resolve() -> None:
    h = Harness()
    h.bind(1, "Reader")
    for name in ("WB1", "AIRCentral", "CNS", "Config", "Psyclone", "AIRServer", "Reader"):
        answer = h.reply(2, "RESOLVE_REQUEST", content=name, language="English")
        assert answer.type == "RESOLVE_SUCCESS", name  # OA-SESS-8, OA-SESS-9
        location = parse_tcplocation(answer.content)
        assert (location.address, location.port, location.name) == ("127.0.0.1", 10000, name)
    for name in ("wb1", "NoSuchWB", ""):
        answer = h.reply(2, "RESOLVE_REQUEST", content=name)
        assert answer.type == "RESOLVE_FAILED" and answer.content == ""


@pytest.mark.parametrize(
    "to", ["", "CNS", "Config", "Psyclone", "AIRServer", "ContextsAndPhases", "WB1", "AIRCentral"]
)
def test_ping_and_keepalive_everywhere(to: str) -> None:
    h = Harness()
    ping = h.reply(1, "PING", to=to)
    assert ping.type == "PING_SUCCESS" and ping.sender == (to or "CNS")  # OA-SESS-10
    keep = Message(type="KEEPALIVE")
    (answer,) = h.send(1, Message(type="KEEPALIVE", to=to, id=keep.id)).replies
    assert answer.type == "KEEPALIVESUCCESS" and answer.isresponse == keep.id  # OA-KEEP-2


def test_status() -> None:
    answer = Harness().reply(1, "STATUS")
    entries = dict(parse_dictionary(answer.content).entries)
    assert answer.type == "STATUS_SUCCESS" and entries["Name"] == "CNS"  # OA-SESS-25
    assert entries["Created"].startswith("2026-")


def test_status_reports_the_counters_for_monitors() -> None:
    h = Harness()
    h.post(2, "Test.Status.A")
    h.post(2, "Test.Status.B")
    h.router.status_extra = lambda: {"queues": {"M": {"depth": 3}}, "connections": 4}
    entries = dict(parse_dictionary(h.reply(1, "STATUS").content).entries)
    assert entries["whiteboards.WB1.received"] == "2"
    assert entries["whiteboards.WB1.stored"] == "2"
    assert entries["whiteboards.WB2.received"] == "0"
    assert entries["queues.M.depth"] == "3" and entries["connections"] == "4"


def test_capabilities() -> None:
    h = Harness(limits=ServerLimits(max_queue=77))
    answer = h.reply(1, "GET_CAPABILITIES")
    caps = parse_capabilities(answer.content)  # OA-CAP-1, OA-LIM-4
    assert answer.type == "CAPABILITIES" and caps.server == "openair-kit/test"
    assert caps.extensions == ("noreply", "pipelining", "usec", "gettime")
    assert caps.limit("max-queue", 0) == 77
    assert caps.limits == ServerLimits(max_queue=77).advertised()


def test_get_time() -> None:
    h = Harness()
    answer = h.reply(1, "GET_TIME")
    assert answer.type == "TIME" and parse_time(answer.content).usec is None  # OA-EXT-2
    h.send(
        2,
        Message(type="BIND", sender="U", to="CNS", extras=(Slot(name="extensions", value="usec"),)),
    )
    timed = h.reply(2, "GET_TIME", sender="U")
    assert parse_time(timed.content).usec is not None  # OA-TIME-5: declared
    legacy = Harness(extensions=frozenset())
    assert legacy.reply(1, "GET_TIME").type == "UNKNOWN_COMMAND"  # OA-CAP-3


def test_get_entry() -> None:
    spec = (
        b'<psySpec name="Demo" version="1.2"><global><title>T</title></global>'
        b'<module name="M"><trigger from="WB1" type="A.*"/></module></psySpec>'
    )
    h = Harness(parse_config(spec, source="/etc/demo.xml"))
    glob = parse_dictionary(h.reply(1, "GET_ENTRY", to="Config", content="Global").content)
    assert dict(glob.entries) == {
        "spec": "/etc/demo.xml",
        "name": "Demo",
        "title": "T",
        "description": "",
        "datastorefile": "",
        "htmldir": "",
    }  # OA-SESS-12
    module = h.reply(1, "GET_ENTRY", to="Config", content="M")
    assert module.type == "ENTRY" and module.content_is_xml
    assert module.content.startswith('<module name="M">')
    absent = h.reply(1, "GET_ENTRY", to="Config", content="Nobody")
    assert absent.type == "ENTRY" and absent.content == ""


def test_current_phase() -> None:
    h = Harness()
    empty = h.reply(1, "Psyclone.Module.Request.CurrentPhase", to="Psyclone", sender="Reader")
    assert empty.type == "Psyclone.Module.CurrentPhase" and empty.content == ""  # OA-SESS-13
    h.subscribe(1, "Reader", '<module name="Reader"><trigger from="WB1" type="A.*"/></module>')
    phase = h.reply(1, "Psyclone.Module.Request.CurrentPhase", to="Psyclone", sender="Reader")
    assert (
        phase.content_is_xml
        and 'type="A.*"' in phase.content
        and 'module="Reader"' in phase.content
    )


def test_airserver() -> None:
    h = Harness()
    first = h.reply(1, "GET_ID", to="AIRServer")
    assert first.type == "ID" and first.content == h.reply(2, "GET_ID", to="AIRServer").content
    name = h.reply(1, "GET_NAME", to="AIRServer")
    assert (name.type, name.content) == ("NAME", "Default built-in")  # OA-SESS-14
    perf = h.reply(1, "System.PerfStat", to="AIRServer", content="<perfstat/>", content_is_xml=True)
    assert perf.type == "RECEIVE_ACCEPT"


@pytest.mark.parametrize(
    ("to", "type_"),
    [
        ("CNS", "FOO_BAR"),
        ("", "FOO_BAR"),
        ("Config", "GET_ID"),
        ("Psyclone", "X"),
        ("AIRServer", "BIND"),
        ("ContextsAndPhases", "GET_ENTRY"),
    ],
)
def test_unknown_command(to: str, type_: str) -> None:
    answer = Harness().reply(1, type_, to=to)
    assert answer.type == "UNKNOWN_COMMAND"  # OA-SESS-20, OA-SESS-29
    assert answer.content == f"Offending cmd: {type_}"


def test_forward_failed() -> None:
    answer = Harness().reply(1, "Some.Post", to="NoSuchWB")
    assert answer.type == "FORWARD_FAILED"  # OA-SESS-21
    assert answer.content == "Could not forward message to: NoSuchWB"
    assert Harness().reply(1, "Some.Post", to="wb1").type == "FORWARD_FAILED"  # OA-WB-10


def test_forward_to_a_bound_module() -> None:
    h = Harness()
    h.bind(1, "Reader")
    msg = Message(type="Direct.Note", sender="Poster", to="Reader", content="hi", priority=1.5)
    outcome = h.send(2, msg)
    assert [r.type for r in outcome.replies] == ["RECEIVE_ACCEPT"]  # OA-SESS-22
    (delivery,) = outcome.deliveries
    assert delivery.module == "Reader" and delivery.message == msg  # unchanged
    assert delivery.priority == 1.5 and delivery.due_ns == h.now


def test_shutting_down() -> None:
    h = Harness()
    h.router.shutting_down()
    outcome = h.request(1, "PING")
    (answer,) = outcome.replies
    assert answer.type == "RECEIVE_ERROR" and answer.content.startswith("SHUTTING_DOWN")
    assert outcome.close_this  # OA-SESS-24


def test_counters() -> None:
    h = Harness()
    h.bind(1, "Reader")
    h.subscribe(1, "Reader", '<triggers><trigger type="Test.*"/></triggers>')
    h.post(2, "Test.A")
    h.post(2, "Bad*Type")
    h.router.note_delivered("Reader")
    h.router.note_dropped("Reader", 3)
    counters: Any = h.router.counters()
    wb1 = counters["whiteboards"]["WB1"]
    assert (wb1["received"], wb1["stored"], wb1["dispatched"]) == (2, 1, 1)
    reader = counters["modules"]["Reader"]
    assert (reader["queued"], reader["delivered"], reader["dropped"]) == (2, 1, 3)
    assert counters["registrations"] == {"Reader": {"triggers": 1, "retrieves": 0}}
    assert h.now > T0
