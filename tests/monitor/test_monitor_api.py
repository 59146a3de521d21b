"""The JSON API against a live in-process server: overview, lists, filters, details, graph, post."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field

from monitor_helpers import BOUND, get, post_json, run, serving

from openair.client import Module
from openair.protocol.matching import matches
from openair.server.aio.app import Server
from openair_monitor import MonitorOptions
from openair_monitor.tap import RateMeter
from openair_monitor.views import stream_infos

TYPES = ["Test", "Test.A", "Test.A.B", "Other.Test", "Input.Perc", "Test.Needle"]


async def module(server: Server, name: str, *patterns: str) -> Module:
    m = Module(name, port=server.port, listen=False)
    await m.connect()
    if patterns:
        await m.subscribe(list(patterns))
    return m


async def woken(m: Module, type_: str) -> None:
    """Wait for the wakeup whose trigger message has `type_` (phase updates are skipped)."""
    while True:
        event = await m.next_wakeup(timeout=BOUND)
        assert event is not None
        if event.wakeup.trigger is not None and event.wakeup.trigger.type == type_:
            return


def test_overview_shows_whiteboards_and_a_module_that_connects() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            before = (await get(server.port, "/api/overview")).json()
            assert [b["name"] for b in before["whiteboards"]] == ["AIRCentral", "WB1", "WB2"]
            assert all(b["maxcount"] == 10_000 for b in before["whiteboards"])
            assert before["server"]["port"] == server.port
            assert before["server"]["post_enabled"] is False
            assert not [m for m in before["modules"] if m["name"] == "Reader"]
            reader = await module(server, "Reader", "Test.*")
            writer = await module(server, "Writer")
            await writer.post("WB1", "Test.A", "one")
            await woken(reader, "Test.A")
            after = (await get(server.port, "/api/overview")).json()
            rows = {m["name"]: m for m in after["modules"]}
            assert rows["Reader"]["bound"] is True
            assert rows["Reader"]["since_ms"] is not None
            assert rows["Reader"]["registration"]["patterns"] == ["Test.*"]
            assert rows["Writer"]["last_type"] == "Test.A"
            assert rows["Writer"]["posted"] >= 1
            wb1 = next(b for b in after["whiteboards"] if b["name"] == "WB1")
            assert (wb1["received"], wb1["stored"], wb1["count"]) == (1, 1, 1)
            assert wb1["dispatched"] == 1
            await reader.close()
            await writer.close()

    run(go)


def test_whiteboard_messages_are_filtered_with_the_trigger_matcher_and_globs() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            writer = await module(server, "Writer")
            other = await module(server, "Other")
            for t in TYPES:
                await writer.post("WB1", t, f"content of {t}")
            await other.post("WB1", "Test.A", "from the other one")
            port = server.port
            everything = (await get(port, "/api/whiteboards/WB1/messages")).json()
            assert [m["wbid"] for m in everything["messages"]] == list(range(7, 0, -1))
            for pattern in ("Test.*", "*.Test", "Input.Perc.*", "Test.A"):
                listed = (
                    await get(port, f"/api/whiteboards/WB1/messages?pattern={pattern}")
                ).json()
                wanted = [t for t in [*TYPES, "Test.A"] if matches(pattern, t)]
                assert sorted(m["type"] for m in listed["messages"]) == sorted(wanted), pattern
            by_sender = (await get(port, "/api/whiteboards/WB1/messages?from=Oth*")).json()
            assert [m["from"] for m in by_sender["messages"]] == ["Other"]
            by_content = (await get(port, "/api/whiteboards/WB1/messages?content=*Needle")).json()
            assert [m["type"] for m in by_content["messages"]] == ["Test.Needle"]
            newest = (await get(port, "/api/whiteboards/WB1/messages?limit=2&before=6")).json()
            assert [m["wbid"] for m in newest["messages"]] == [5, 4]
            await writer.close()
            await other.close()

    run(go)


def test_bad_queries_get_400_and_unknown_names_404() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            port = server.port
            bad = await get(port, "/api/whiteboards/WB1/messages?pattern=Test..A")
            assert bad.status == 400 and "pattern" in bad.json()["error"]
            assert (await get(port, "/api/whiteboards/WB1/messages?limit=0")).status == 400
            assert (await get(port, "/api/whiteboards/WB1/messages?limit=x")).status == 400
            assert (await get(port, "/api/whiteboards/wb1/messages")).status == 404  # exact case
            assert (await get(port, "/api/messages/WB1/99")).status == 404
            assert (await get(port, "/api/modules/Nobody")).status == 404
            assert (await get(port, "/api/nothing")).status == 404
            assert (await get(port, "/api/whiteboards/%ff/messages")).status == 400

    run(go)


def test_a_message_shows_every_slot_its_latency_cc_and_wakeups() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            reader = await module(server, "Reader", "Test.*")
            copied = await module(server, "Copied")
            writer = await module(server, "Writer")
            sent = await writer.post("WB1", "Test.A", "hello", cc=["Copied"], priority=1.5)
            await woken(reader, "Test.A")
            by_wbid = (await get(server.port, "/api/messages/WB1/1")).json()
            by_id = (await get(server.port, f"/api/messages/WB1/{sent.id}")).json()
            assert by_wbid == by_id
            slots = by_wbid["slots"]
            assert (slots["type"], slots["from"], slots["content"]) == ("Test.A", "Writer", "hello")
            assert slots["priority"] == 1.5 and slots["stored"] == "WB1" and slots["wbid"] == 1
            assert slots["postedTime"]["sec"] > 0 and slots["receivedTime"]["sec"] > 0
            assert isinstance(by_wbid["latency_ms"], float)
            assert by_wbid["cc"] == ["Copied"]
            wakeups = {w["module"]: w for w in by_wbid["wakeups"]}
            assert wakeups["Reader"]["lasttrigger"] == "Test.*"
            assert wakeups["Reader"]["cause"] == "trigger"
            assert wakeups["Copied"]["cause"] == "cc"  # OA-CC-2
            for m in (reader, copied, writer):
                await m.close()

    run(go)


def test_module_detail_has_registration_and_recent_wakeups() -> None:
    async def go() -> None:
        async with serving() as (server, mon):
            reader = await module(server, "Reader", "Test.*", "Other.*")
            writer = await module(server, "Writer")
            await writer.post("WB1", "Test.A", "x")
            await woken(reader, "Test.A")
            d = (await get(server.port, "/api/modules/Reader")).json()
            (phase,) = d["registration"]["phases"]
            assert [t["pattern"] for t in phase["triggers"]] == ["Test.*", "Other.*"]
            assert phase["active"] is True
            assert [w["type"] for w in d["recent_wakeups"]] == ["Test.A"]
            assert d["module"]["bound"] is True
            assert d["latency_measured"] is mon.latency_hooked
            await reader.close()
            await writer.close()

    run(go)


def test_the_graph_links_senders_types_whiteboards_and_woken_modules() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            reader = await module(server, "Reader", "Test.*")
            writer = await module(server, "Writer")
            for _ in range(3):
                await writer.post("WB2", "Test.G", "x")
            await woken(reader, "Test.G")
            g = (await get(server.port, "/api/graph")).json()
            edges = {(e["from"], e["to"]): e for e in g["edges"]}
            assert edges[("src:Writer", "type:Test.G")]["count"] == 3
            assert edges[("type:Test.G", "wb:WB2")]["count"] == 3
            assert edges[("wb:WB2", "dst:Reader")]["count"] == 3
            assert edges[("wb:WB2", "dst:Reader")]["rate"] > 0
            kinds = {n["id"]: n["kind"] for n in g["nodes"]}
            assert kinds["src:Writer"] == "sender" and kinds["dst:Reader"] == "receiver"
            await reader.close()
            await writer.close()

    run(go)


def test_the_streams_panel_lists_the_configured_streams() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            expected = server.counters()["streams"]
            assert isinstance(expected, dict)
            overview = (await get(server.port, "/api/overview")).json()
            rows = {s["name"]: s for s in overview["streams"]}
            assert set(rows) == set(expected)
            for name, row in rows.items():
                assert row["whiteboard"] == expected[name]["whiteboard"]
                assert row["fill_hard"] == 0.0  # empty, against maxsize or hardsize
            assert (await get(server.port, "/api/streams")).json()["streams"] == overview["streams"]

    run(go)


@dataclass
class StreamsOnly:
    """What `stream_infos` reads from a monitor."""

    table: dict[str, dict[str, str]]
    rates: RateMeter = field(default_factory=RateMeter)

    def streams(self, counters: object = None) -> dict[str, dict[str, str]]:
        return self.table


def test_stream_fill_is_measured_against_soft_and_hard_limits() -> None:
    typed = {"size": "50", "softsize": "100", "hardsize": "200", "count": "3",
             "softcount": "4", "hardcount": "0", "maxcount": "0", "added": "7"}  # fmt: skip
    plain = {"size": "5", "maxsize": "10", "count": "1", "maxcount": "0"}
    rows = stream_infos(StreamsOnly({"T": typed, "P": plain, "Odd": {}}), 0.0)  # type: ignore[arg-type]
    by_name = {r["name"]: r for r in rows}
    assert by_name["T"]["fill_soft"] == 0.75  # the count is fuller than the size
    assert by_name["T"]["fill_hard"] == 0.25  # hardcount 0: no count limit
    assert by_name["P"]["fill_soft"] is None and by_name["P"]["fill_hard"] == 0.5
    assert by_name["P"]["rate"] is None  # no `added` counter: no rate
    assert by_name["Odd"] == {"name": "Odd", "rate": None, "fill_soft": None, "fill_hard": None}


def test_post_is_refused_without_monitor_post() -> None:
    async def go() -> None:
        async with serving() as (server, _):
            reply = await post_json(server.port, {"to": "WB1", "type": "Test.A"})
            assert reply.status == 403 and "--monitor-post" in reply.json()["error"]
            assert server.router.whiteboard("WB1") is not None
            assert len(server.router.whiteboard("WB1")) == 0  # type: ignore[arg-type]

    run(go)


def test_post_is_refused_from_an_address_not_in_monitor_hosts() -> None:
    async def go() -> None:
        async with serving(monitor_post=True, monitor_hosts=("10.9.9.9",)) as (server, _):
            reply = await post_json(server.port, {"to": "WB1", "type": "Test.A"})
            assert reply.status == 403 and "127.0.0.1" in reply.json()["error"]

    run(go)


def test_post_goes_through_the_router_and_wakes_modules() -> None:
    async def go() -> None:
        async with serving(monitor_post=True) as (server, _):
            reader = await module(server, "Reader", "Test.*")
            body = {"from": "Console", "to": "WB1", "type": "Test.Posted", "cc": "A, B",
                    "priority": 3, "content": "<a>x</a>", "xml": True}  # fmt: skip
            reply = await post_json(server.port, body)
            assert reply.status == 200, reply.body
            data = reply.json()
            assert data["accepted"] and data["wbid"] == 1
            assert data["reply"]["type"] == "RECEIVE_ACCEPT"
            await woken(reader, "Test.Posted")
            stored = (await get(server.port, "/api/messages/WB1/1")).json()["slots"]
            assert (stored["from"], stored["cc"], stored["priority"]) == ("Console", "A;B", 3.0)
            assert stored["contentIsXml"] is True and stored["content"] == "<a>x</a>"
            await reader.close()

    run(go)


def test_bad_posts_are_refused_with_a_reason() -> None:
    async def go() -> None:
        async with serving(monitor_post=True) as (server, _):
            port = server.port
            cases = [
                ({"to": "WB1", "type": "Bad..Type"}, 400),
                ({"to": "CNS", "type": "BIND"}, 400),  # only whiteboards
                ({"to": "WB1", "type": "AIR.Subscribe"}, 400),
                ({"to": "WB1", "type": "T", "priority": 9}, 400),
                ({"to": "WB1", "type": "T", "content": "<a>", "xml": True}, 400),
                ({"to": "WB1", "type": "T", "content": 5}, 400),
                (["not", "an", "object"], 400),
            ]
            for body, status in cases:
                reply = await post_json(port, body)
                assert reply.status == status, (body, reply.body)
                assert reply.json()["error"]
            text = await post_json(port, {"to": "WB1", "type": "T"}, {"Content-Type": "text/plain"})
            assert text.status == 415
            foreign = await post_json(
                port, {"to": "WB1", "type": "T"}, {"Origin": "http://evil.example"}
            )
            assert foreign.status == 403
            same = await post_json(
                port, {"to": "WB1", "type": "T"}, {"Origin": f"http://127.0.0.1:{port}"}
            )
            assert same.status == 200
            wrong_method = await get(port, "/api/post")
            assert wrong_method.status == 405 and wrong_method.headers["allow"] == "POST"

    run(go)


def test_latency_is_recorded_when_the_dispatcher_reports_deliveries() -> None:
    async def go() -> None:
        async with serving(monitor=MonitorOptions()) as (server, mon):
            reader = await module(server, "Reader", "Test.*")
            writer = await module(server, "Writer")
            await writer.post("WB1", "Test.A", "x")
            await woken(reader, "Test.A")
            await asyncio.wait_for(server.dispatcher.drained(), BOUND)  # the ack is in
            if not mon.latency_hooked:
                assert "Reader" not in mon.tap.latency  # nothing is made up
            else:
                hist = (await get(server.port, "/api/modules/Reader")).json()["latency"]
                assert hist["count"] >= 1
            await reader.close()
            await writer.close()

    run(go)


def test_rates_sample_the_bound_modules_only() -> None:
    """Issue #19, item 7: a sample costs what is live, however many gone names are kept."""

    async def go() -> None:
        async with serving() as (server, _):
            stays = await module(server, "Stays", "Test.*")
            goes = await module(server, "Goes")
            await goes.post("WB1", "Test.A", "one")
            await woken(stays, "Test.A")
            await goes.close()
            for _ in range(int(BOUND / 0.01)):
                if server.router.module("Goes") is None:
                    break
                await asyncio.sleep(0.01)
            sampled = server.rate_counters()
            assert set(sampled["modules"]) == {"out:Stays", "in:Stays"}
            assert sampled["modules"]["in:Stays"] >= 1
            assert "Goes" in server.counters()["modules"]  # still kept (OA-LIM-15)
            assert sampled["whiteboards"]["wb:WB1"] == 1
            await stays.close()

    run(go)
