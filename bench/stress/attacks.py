"""The attacks of issue #19, each a coroutine that returns its figures.

Every attack gets the server's main port and returns `Figures`: what it measured, and whether
the bound it aims at held. Sizes are chosen to pass the default budgets of the stress server
(`__main__`) many times over while a run stays near a minute on a small machine.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field

from bench.stress.wire import Raw, frame_of
from openair.protocol.codec import to_frame
from openair.protocol.framing import FrameTag, encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary

__all__ = ["ATTACKS", "Attack", "Figures", "status"]

MIB = 1 << 20


@dataclass(slots=True)
class Figures:
    """What one attack measured; `held` is False when the bound it aims at did not hold."""

    held: bool = True
    notes: dict[str, object] = field(default_factory=dict)


async def status(port: int) -> dict[str, str]:
    """Return the server's STATUS entries (a fresh connection)."""
    raw = await Raw.open(port)
    try:
        reply = await raw.request(Message(type="STATUS", to="CNS", sender="Stress"))
    finally:
        raw.close()
    return dict(parse_dictionary(reply.content).entries) if reply is not None else {}


async def _module(port: int, name: str, registration: str) -> tuple[Raw, Raw]:
    """Bind `name` without a port, open its callback connection, subscribe; return both."""
    primary = await Raw.open(port)
    await primary.request(Message(type="BIND_NOLISTEN", to="CNS", sender=name))
    callback = await Raw.open(port)
    callback.send(
        Message(type="RECEIVE_NAME_NOTIFICATION", to="CNS", sender=name), FrameTag.RECEIVE
    )
    sub = Message(
        type="AIR.Subscribe", to="WB1", sender=name, content=registration, content_is_xml=True
    )
    reply = await primary.request(sub)
    assert reply is not None and reply.type == "RECEIVE_ACCEPT", reply
    return primary, callback


async def _post_many(port: int, n: int, size: int, kind: str = "Test.Big") -> int:
    """Post `n` messages of `size` content bytes, pipelined 32 at a time; return how many acked."""
    raw = await Raw.open(port)
    acked = 0
    body = "x" * size
    try:
        for start in range(0, n, 32):
            batch = range(start, min(n, start + 32))
            for i in batch:
                raw.send(Message(type=f"{kind}.{i}", to="WB1", sender="Poster", content=body))
            for _ in batch:
                reply = await raw.recv()
                acked += reply is not None and reply.type == "RECEIVE_ACCEPT"
    finally:
        raw.close()
    return acked


async def stalled_subscriber(port: int) -> Figures:
    """Item 1: 300 x 1 MiB posts to a module that never acknowledges, then the module leaves."""
    trig = '<triggers><trigger from="WB1" type="Test.*"/></triggers>'
    primary, callback = await _module(port, "Stalled", trig)
    acked = await _post_many(port, 300, MIB)
    during = await status(port)
    primary.close()
    callback.close()
    await asyncio.sleep(0.5)  # let the server see the module go (a benchmark, not a test)
    after = await status(port)
    queue = int(during.get("queues.Stalled.bytes", "0"))
    fig = Figures(held=acked == 300 and queue <= 32 * MIB + 2 * MIB)
    fig.notes = {
        "acked": acked,
        "queue_MiB": round(queue / MIB, 1),
        "dropped": during.get("queues.Stalled.dropped", "?"),
        "queue_after_leave_MiB": round(int(after.get("queues.Stalled.bytes", "0")) / MIB, 1),
    }
    return fig


async def fill_board(port: int) -> Figures:
    """Setup of items 2 and 6: 5 000 posts of 1 KiB (not timed: posting is not the attack)."""
    acked = await _post_many(port, 5000, 1024, kind="Test.Fill")
    return Figures(held=acked == 5000, notes={"filled": acked})


async def wakeup_retrieves(port: int) -> Figures:
    """Item 2: a registration with 20 `latest=0` retrieves on a board of 5 000 posts."""
    retrieves = '<retrieve type="Test.*"><latest>0</latest></retrieve>' * 20
    reg = (
        '<module name="Greedy"><triggers from="WB1"><trigger type="Test.Go.*"/></triggers>'
        f"<retrieves>{retrieves}</retrieves></module>"
    )
    primary, callback = await _module(port, "Greedy", reg)
    poster = await Raw.open(port)
    sizes: list[int] = []
    for i in range(5):
        poster.send(Message(type=f"Test.Go.{i}", to="WB1", sender="Poster"))
        await poster.recv()
        wakeup = await callback.recv()
        if wakeup is None:
            break
        sizes.append(len(wakeup.content))
        callback.send(wakeup.reply("RECEIVE_ACCEPT", sender="Greedy"))
    for raw in (poster, primary, callback):
        raw.close()
    largest = max(sizes, default=0)
    fig = Figures(held=len(sizes) == 5 and largest <= 8 * MIB)
    fig.notes = {"wakeups": len(sizes), "largest_wakeup_KiB": largest // 1024}
    return fig


async def big_retrieves(port: int) -> Figures:
    """Item 6: ten concurrent `latest=0` AIR.Retrieve of 10 000 posts (10 MiB each reply).

    The board holds twice `fill_board`; the retrieve names the type of those posts, so each
    answer is a real one of 10 MiB, not a quick refusal for passing max-frame-xml (the board
    also holds the megabyte posts of `stalled_subscriber`).
    """
    raws = [await Raw.open(port) for _ in range(10)]
    spec = '<retrieve type="Test.Fill.*"><latest>0</latest></retrieve>'
    msg = Message(type="AIR.Retrieve", to="WB1", sender="Reader", content=spec, content_is_xml=True)
    replies = await asyncio.gather(*(raw.request(msg) for raw in raws))
    for raw in raws:
        raw.close()
    kinds = sorted({r.type if r is not None else "closed" for r in replies})
    largest = max((len(r.content) for r in replies if r is not None), default=0)
    notes: dict[str, object] = {"replies": ",".join(kinds), "largest_MiB": round(largest / MIB, 1)}
    return Figures(held=None not in replies, notes=notes)


async def connection_flood(port: int) -> Figures:
    """Item 5: 600 connections from one address; how many does the server keep?"""
    raws: list[Raw] = []
    for _ in range(600):
        with contextlib.suppress(OSError):
            raws.append(await Raw.open(port))
    answers = await asyncio.gather(
        *(raw.request(Message(type="PING", to="CNS", sender="Flood")) for raw in raws),
        return_exceptions=True,
    )
    kept = sum(1 for a in answers if isinstance(a, Message))
    for raw in raws:
        raw.close()
    return Figures(held=kept <= 256, notes={"opened": len(raws), "served": kept})


async def slowloris(port: int) -> Figures:
    """Item 5: 40 connections each hold half of an 8 MiB frame (320 MiB if all were kept)."""
    frame = frame_of(Message(type="Test.Slow", to="WB1", sender="Slow", content="x" * 8 * MIB))
    raws = [await Raw.open(port) for _ in range(40)]
    for raw in raws:
        raw.writer.write(frame[: 4 * MIB])
        await raw.writer.drain()
    await asyncio.sleep(1.0)
    during = await status(port)
    for raw in raws:
        raw.close()
    partial = int(during.get("budget.partial_bytes", "0"))
    fig = Figures(held=partial <= 64 * MIB + MIB)
    fig.notes = {
        "partial_MiB": round(partial / MIB, 1),
        "refused": during.get("budget.refused_partial", "?"),
    }
    return fig


async def char_refs(port: int) -> Figures:
    """Item 6: one 15 MiB post of character references (its decode must not hold the loop)."""
    raw = await Raw.open(port)
    msg = Message(type="Test.Refs", to="WB1", sender="Refs", content="<r/>", content_is_xml=True)
    frame = to_frame(msg)  # the references go in raw: the writer would resolve them
    xml = frame.xml.replace(b"<r/>", b"<r>" + b"&#65;" * (15 * MIB // 5) + b"</r>")
    raw.writer.write(encode_frame(dataclasses.replace(frame, xml=xml)))
    reply = await raw.recv()
    raw.close()
    return Figures(held=reply is not None, notes={"reply": reply.type if reply else "closed"})


async def monitor_half_requests(port: int) -> Figures:
    """Item 9: 130 half-sent HTTP requests from one address; can another address still get in?"""
    writers: list[asyncio.StreamWriter] = []
    for _ in range(130):
        with contextlib.suppress(OSError):
            _, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.write(b"GET / HTTP/1.1\r\nHost: localhost\r\n")
            writers.append(writer)
    reader, writer = await asyncio.open_connection("127.0.0.1", port, local_addr=("127.0.0.2", 0))
    writer.write(b"GET /api/overview HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
    line = await asyncio.wait_for(reader.readline(), 30.0)
    writer.close()
    rebound = await _http_status(port, b"evil.example")
    for w in writers:
        w.close()
    other = line.split(b" ")[1].decode() if line else "closed"
    fig = Figures(held=other == "200" and rebound == "403")
    fig.notes = {"other_peer": other, "rebound_host": rebound}
    return fig


async def _http_status(port: int, host: bytes) -> str:
    reader, writer = await asyncio.open_connection("127.0.0.1", port, local_addr=("127.0.0.3", 0))
    writer.write(b"GET /api/overview HTTP/1.1\r\nHost: " + host + b"\r\nConnection: close\r\n\r\n")
    line = await asyncio.wait_for(reader.readline(), 30.0)
    writer.close()
    return line.split(b" ")[1].decode() if line else "closed"


async def create_streams(port: int) -> Figures:
    """Item 3: 200 run-time streams asked for, half of them of a terabyte.

    Held when no more than max-created-streams (64 by default) were made, and none whose
    maxsize passes max-created-stream-bytes.
    """
    raw = await Raw.open(port)
    made = refused_big = 0
    try:
        for i in range(200):
            size = 1_000_000 if i % 2 else 1  # MiB: a terabyte, or one MiB
            content = f'<stream name="StressStream{i}" whiteboard="WB1" maxsize="{size}"/>'
            reply = await raw.request(
                Message(
                    type="Psyclone.System.Create.Stream",
                    sender="StreamMaker",
                    to="Psyclone",
                    content=content,
                    content_is_xml=True,
                    language="xml",
                )
            )
            accepted = reply is not None and reply.type == "RECEIVE_ACCEPT"
            made += accepted
            refused_big += bool(i % 2) and not accepted
    finally:
        raw.close()
    fig = Figures(held=made <= 64 and refused_big == 100)
    fig.notes = {"created": made, "terabyte_refused": refused_big}
    return fig


async def history_bytes(port: int) -> Figures:
    """Item 4: 200 posts of 1 MiB to a whiteboard nobody subscribes to (history by bytes)."""
    raw = await Raw.open(port)
    body = "x" * MIB
    acked = 0
    try:
        for start in range(0, 200, 20):
            for i in range(start, start + 20):
                raw.send(Message(type=f"Hist.Big.{i}", to="WB2", sender="Historian", content=body))
            for _ in range(20):
                reply = await raw.recv()
                acked += reply is not None and reply.type == "RECEIVE_ACCEPT"
    finally:
        raw.close()
    kept = int((await status(port)).get("whiteboards.WB2.count", "0"))
    fig = Figures(held=acked == 200 and kept <= 64)  # 64 MiB of history: 63 or 64 of them
    fig.notes = {"acked": acked, "kept": kept}
    return fig


async def forgotten_names(port: int) -> Figures:
    """Item 7: 3 000 module names bound once and gone; past the retention they are forgotten."""
    for start in range(0, 3000, 100):
        raws = [await Raw.open(port) for _ in range(100)]
        for i, raw in enumerate(raws):
            raw.send(Message(type="BIND_NOLISTEN", to="CNS", sender=f"Gone{start + i}"))
            raw.send(Message(type="PING", to="CNS", sender=f"Gone{start + i}"))  # counted
        for raw in raws:
            await raw.recv()
            await raw.recv()
            raw.close()
    during = len({k.split(".")[1] for k in await status(port) if k.startswith("modules.Gone")})
    await asyncio.sleep(RETENTION_MS / 1000 * 1.5)  # the sweep may run 25 % late
    after = {k.split(".")[1] for k in await status(port) if k.startswith("modules.Gone")}
    fig = Figures(held=not after)  # those seen before may be fewer: the first go during
    fig.notes = {"names_before": during, "names_after_retention": len(after)}
    return fig


#: The stress server's --module-retention-ms (item 7 waits for it).
RETENTION_MS = 2000

Attack = Callable[[int], Awaitable[Figures]]

#: (name, issue item, attack, budget in MiB the server's growth is judged against, setup run
#: before the attack's quiet period, neither timed nor judged)
ATTACKS: tuple[tuple[str, str, Attack, int, Attack | None], ...] = (
    # queue + history + the monitor's ring + the router's cache of encoded copies
    ("stalled-subscriber", "1", stalled_subscriber, 32 + 64 + 32 + 16, None),
    ("wakeup-retrieves", "2", wakeup_retrieves, 64 + 4 * 5, fill_board),
    # ten replies of 10 MiB written one at a time, each held until its reader took it
    ("big-retrieves", "6", big_retrieves, 16 * 10, fill_board),
    ("connection-flood", "5", connection_flood, 64, None),
    ("slowloris-partial-frames", "5", slowloris, 64, None),
    ("create-streams", "3", create_streams, 16, None),
    # history + the monitor's ring + the router's cache of encoded copies
    ("history-bytes", "4", history_bytes, 64 + 32 + 16, None),
    ("forgotten-names", "7", forgotten_names, 32, None),
    ("char-refs-16MiB", "6", char_refs, 16 * 4, None),
    ("monitor-half-requests", "9", monitor_half_requests, 16, None),
)
