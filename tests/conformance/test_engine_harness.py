"""The harness: delivery paths, barrier, held acknowledgements, answers on listener connections."""

from __future__ import annotations

import asyncio
import struct
from collections.abc import Awaitable, Callable

import pytest
from lxml import etree

from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import wakeup_view
from openair_conformance.harness.probe import probe
from openair_conformance.model import CaseInfo, Fail, Inconclusive, Level, NotApplicable

_HEADER = struct.Struct("<7sxI")


def _in_context(
    target: tuple[str, int],
    body: Callable[[CaseContext], Awaitable[None]],
    *,
    scale: float = 1.0,
) -> CaseContext:
    async def scenario() -> CaseContext:
        server = await probe(*target)
        info = CaseInfo(
            id="HARN-001", title="t", section="6", requirements=("OA-DELIV-2",), level=Level.MUST
        )
        ctx = CaseContext(
            case=info,
            target=target,
            rtt=server.rtt_ms / 1000,
            timeout_scale=scale,
            server=server,
            run_id="t001",
        )
        try:
            await body(ctx)
        finally:
            await ctx.aclose()
        return ctx

    return asyncio.run(scenario())


async def _subscribe_and_post(
    ctx: CaseContext, sub_suffix: str, *, listen: bool = True, callback: bool = True
) -> str:
    sub = await ctx.module(sub_suffix, listen=listen, callback=callback)
    await sub.subscribe(f'<triggers><trigger type="{ctx.type("T.*")}"/></triggers>', check=True)
    poster = await ctx.module("P", bind=False)
    await poster.post("WB1", ctx.type("T.1"), "x")
    assert poster.last_sent is not None
    await sub.expect_wakeup_for(poster.last_sent.id)
    return sub.delivery_paths[-1]


def test_listener_path_when_there_is_no_callback(fake_target: tuple[str, int]) -> None:
    paths: list[str] = []

    async def body(ctx: CaseContext) -> None:
        paths.append(await _subscribe_and_post(ctx, "L", callback=False))

    ctx = _in_context(fake_target, body)
    assert paths == ["listener"]
    assert any(e.conn == "L/listener#1" and e.direction == "in" for e in ctx.trace.entries)


def test_callback_path_after_bind_nolisten(fake_target: tuple[str, int]) -> None:
    paths: list[str] = []

    async def body(ctx: CaseContext) -> None:
        paths.append(await _subscribe_and_post(ctx, "N", listen=False))

    ctx = _in_context(fake_target, body)
    assert paths == ["callback"]
    assert any("BIND_NOLISTEN" in e.text for e in ctx.trace.entries if e.direction == "out")


def test_barrier_returns_the_wakeups_before_the_sentinel(fake_target: tuple[str, int]) -> None:
    seen: list[list[str]] = []

    async def body(ctx: CaseContext) -> None:
        sub = await ctx.module("S")
        await sub.subscribe(f'<triggers><trigger type="{ctx.type("B.*")}"/></triggers>', check=True)
        poster = await ctx.module("P", bind=False)
        for n in (1, 2):
            await poster.post("WB1", ctx.type(f"B.{n}"), str(n))
        first = await sub.barrier()
        second = await sub.barrier()
        for batch in (first, second):
            seen.append([wakeup_view(w).trigger.type for w in batch])  # type: ignore[union-attr]

    ctx = _in_context(fake_target, body)
    assert seen == [[ctx.type("B.1"), ctx.type("B.2")], []]


def test_barrier_without_a_wakeup_is_inconclusive(fake_target: tuple[str, int]) -> None:
    async def body(ctx: CaseContext) -> None:
        client = await ctx.module("U", bind=False)  # never bound: cc cannot wake it
        with pytest.raises(Inconclusive, match="cannot prove absence"):
            await client.barrier()

    _in_context(fake_target, body, scale=0.05)


def test_missing_wakeup_fails(fake_target: tuple[str, int]) -> None:
    async def body(ctx: CaseContext) -> None:
        sub = await ctx.module("S")
        with pytest.raises(Fail, match="no wakeup for"):
            await sub.next_wakeup()

    _in_context(fake_target, body, scale=0.05)


def test_acknowledgements_can_be_held(fake_target: tuple[str, int]) -> None:
    async def body(ctx: CaseContext) -> None:
        sub = await ctx.module("S")
        await sub.subscribe(f'<triggers><trigger type="{ctx.type("H.*")}"/></triggers>', check=True)
        poster = await ctx.module("P", bind=False)
        sub.pause_acks()
        await poster.post("WB1", ctx.type("H.1"), "1")
        wakeup = await sub.next_wakeup()
        acks = [e for e in ctx.trace.entries if e.direction == "out" and wakeup.id in e.text]
        assert acks == []  # held
        sub.resume_acks()
        await poster.post("WB1", ctx.type("H.2"), "2")
        await sub.next_wakeup()  # the fake server sends the next one only after the first ack
        acks = [e for e in ctx.trace.entries if e.direction == "out" and wakeup.id in e.text]
        assert len(acks) == 1 and "RECEIVE_ACCEPT" in acks[0].text

    _in_context(fake_target, body)


def test_undeclarable_extension_is_not_applicable(fake_target: tuple[str, int]) -> None:
    async def body(ctx: CaseContext) -> None:
        with pytest.raises(NotApplicable, match="noreply"):
            await ctx.module("X", extensions=("noreply",))

    _in_context(fake_target, body)


def _frame(xml: bytes) -> bytes:
    return _HEADER.pack(b"Message", len(xml)) + xml


async def _exchange(port: int, xml: bytes) -> etree._Element:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(_frame(xml))
    _, length = _HEADER.unpack(await reader.readexactly(12))
    reply = etree.fromstring(await reader.readexactly(length))
    writer.close()
    return reply


def test_module_answers_server_requests_on_its_listener(fake_target: tuple[str, int]) -> None:
    # Play the server: connect to the module's port as a whiteboard would (OA-SESS-11).
    async def body(ctx: CaseContext) -> None:
        sub = await ctx.module("S", callback=False)
        assert sub.listen_port is not None
        port = sub.listen_port
        cases = [
            ("PING", "PING_SUCCESS"),
            ("KEEPALIVE", "KEEPALIVESUCCESS"),
            ("Some.Forwarded", "RECEIVE_ACCEPT"),
        ]
        for n, (request, answer) in enumerate(cases):
            xml = (
                f"<message><type>{request}</type><id>req-{n}</id><from>WB1</from>"
                f"<to>{sub.name}</to></message>"
            ).encode()
            reply = await _exchange(port, xml)
            assert (reply.findtext("type"), reply.findtext("isresponse")) == (answer, f"req-{n}")
        assert [m.type for m in sub.deliveries_seen] == ["Some.Forwarded"]
        assert (await sub.next_delivery()).type == "Some.Forwarded"
        bad = await _exchange(port, b"<message><type>AIR.Instruct.Wakeup</type")
        assert bad.findtext("type") == "RECEIVE_ERROR"
        with pytest.raises(Fail, match="cannot decode"):
            await sub.next_wakeup()

    _in_context(fake_target, body)
