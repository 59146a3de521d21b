"""A three-node cluster behaves as one server (spec 17): posts, retrieves and wakeups across nodes.

Each node runs in its own network namespace with its own nats-server (netcluster.py); the
clients run in a fifth namespace. OA-CLU-1 (one wbid order), OA-CLU-3 (retrieve sees every
acknowledged post), OA-CLU-4 (wakeups for posts stored elsewhere), OA-CLU-6 (placement).
"""

from __future__ import annotations

import asyncio
import secrets

import pytest
from netcluster import Cluster, run_in

from openair.client.module import Module
from openair.protocol.codec import from_frame, to_frame
from openair.protocol.content import RetrieveSpec
from openair.protocol.framing import FrameReader, encode_frame
from openair.protocol.message import Message

pytestmark = pytest.mark.slow


def _client(cluster: Cluster, index: int, name: str, **kw: object) -> Module:
    node = cluster.nodes[index]
    return Module(name, node.address, 10000, listen=False, reconnect=False, **kw)  # type: ignore[arg-type]


async def _all(module: Module, board: str, pattern: str = "*") -> list[Message]:
    spec = RetrieveSpec(whiteboard=board, pattern=pattern, latest=0)
    return await module.retrieve(spec, to=board)


def test_posts_on_every_node_have_one_wbid_order_everywhere(cluster: Cluster) -> None:
    tag = "Basic.T" + secrets.token_hex(3)

    async def body() -> list[list[tuple[int, str]]]:
        clients = [_client(cluster, i, f"Poster{i}", bind=False) for i in range(3)]
        for c in clients:
            await c.connect()
        try:
            for round_ in range(5):
                await asyncio.gather(
                    *(c.post("WB1", f"{tag}.P", f"{i}-{round_}") for i, c in enumerate(clients))
                )
            seen = []
            for c in clients:  # OA-CLU-3: each node sees all 15, at once
                got = await _all(c, "WB1", f"{tag}.*")
                seen.append([(m.wbid or 0, m.content) for m in got])
            return seen
        finally:
            for c in clients:
                await c.close()

    seen = run_in(cluster.client_ns, body())
    assert len(seen[0]) == 15
    assert {content for _, content in seen[0]} == {f"{i}-{r}" for i in range(3) for r in range(5)}
    wbids = [w for w, _ in seen[0]]
    assert len(set(wbids)) == 15 and wbids == sorted(wbids, reverse=True)  # OA-CLU-1
    assert seen[1] == seen[0] and seen[2] == seen[0]  # the same order on every node
    # Each poster's own posts keep their order (one connection's order).
    for i in range(3):
        mine = [w for w, c in reversed(seen[0]) if c.startswith(f"{i}-")]
        assert [c for _, c in sorted(seen[0]) if c.startswith(f"{i}-")] == [
            f"{i}-{r}" for r in range(5)
        ]
        assert mine == sorted(mine)


def test_a_post_on_one_node_wakes_modules_on_the_others(cluster: Cluster) -> None:
    tag = "Wake.T" + secrets.token_hex(3)

    async def body() -> tuple[list[str], list[str], list[str]]:
        watcher = _client(cluster, 1, f"Watch{tag[-6:]}")
        cc_target = _client(cluster, 2, f"Cc{tag[-6:]}")
        poster = _client(cluster, 0, "PosterW", bind=False)
        for m in (watcher, cc_target, poster):
            await m.connect()
        try:
            await watcher.subscribe(f"{tag}.*")
            for n in range(3):
                await poster.post("WB2", f"{tag}.Ping", f"p{n}")
            await poster.post("WB2", "Other.Thing", "cc'd", cc=cc_target.name)  # OA-CC-1
            await poster.post("WB1", f"{tag}.Ping", "noreply", noreply=True)  # OA-CLU-5
            woken = [await _next_trigger(watcher) for _ in range(4)]
            cc = [await _next_trigger(cc_target)]
            # Nothing more for the cc target: it has no triggers (a wakeup would be a bug).
            extra = await cc_target.next_wakeup(timeout=0.5)
            return woken, cc, [] if extra is None else [extra.message.type]
        finally:
            for m in (watcher, cc_target, poster):
                await m.close()

    woken, cc, extra = run_in(cluster.client_ns, body())
    assert woken == ["p0", "p1", "p2", "noreply"]  # OA-CLU-4, in wbid order
    assert cc == ["cc'd"]
    assert extra == []


async def _next_trigger(module: Module) -> str:
    while True:
        event = await module.next_wakeup(timeout=15.0)
        assert event is not None, "no wakeup within 15 s"
        trigger = event.wakeup.trigger
        if trigger is not None:  # a phase update has none
            return trigger.content


def test_maxcount_holds_on_every_node(cluster: Cluster) -> None:
    async def body() -> list[list[str]]:
        clients = [_client(cluster, i, f"Max{i}", bind=False) for i in range(3)]
        for c in clients:
            await c.connect()
        try:
            for n in range(12):
                await clients[n % 3].post("Small", "Max.Fill", str(n))
            return [[m.content for m in await _all(c, "Small")] for c in clients]
        finally:
            for c in clients:
                await c.close()

    kept = run_in(cluster.client_ns, body())
    assert kept == [["11", "10", "9", "8", "7"]] * 3  # OA-WB-6 on every node


def test_a_whiteboard_placed_on_a_node_lives_there_and_works_from_any_node(
    cluster: Cluster,
) -> None:
    async def body() -> tuple[list[str], str]:
        import nats

        from openair.cluster.store import stream_name

        clients = [_client(cluster, i, f"Vis{i}", bind=False) for i in range(3)]
        for c in clients:
            await c.connect()
        try:
            await clients[0].post("Vision", "Vision.Frame", "from n1")
            await clients[1].post("Vision", "Vision.Frame", "from n2")
            got = [m.content for m in await _all(clients[2], "Vision")]
        finally:
            for c in clients:
                await c.close()
        nc = await nats.connect(f"nats://{cluster.nodes[0].address}:4222")
        try:
            info = await nc.jetstream().stream_info(stream_name("Vision"))
            leader = info.cluster.leader if info.cluster else ""
        finally:
            await nc.close()
        return got, leader or ""

    got, leader = run_in(cluster.client_ns, body())
    assert got[:2] == ["from n2", "from n1"]
    assert leader == "n3"  # OA-CLU-6: host="n3" is the placement tag of node n3


def test_a_retrieve_reads_the_whiteboards_it_names_up_to_date(cluster: Cluster) -> None:
    """OA-CLU-3 for a retrieve addressed to one whiteboard that reads another.

    A node caught up only with the addressee (AIRCentral) and answered from what it held of
    the whiteboard named in `from`: a noreply post and a retrieve right behind it on the same
    node found nothing (conformance case MSG-008 run alone). Each retrieve here reads WB1
    through AIRCentral right after a post: on the posting node it must see every post made
    there and every acknowledged one; on another node every acknowledged one.
    """
    tag = "Named.T" + secrets.token_hex(3)

    async def body() -> list[set[str]]:
        posters = [_client(cluster, i, f"NPoster{i}", bind=False) for i in range(3)]
        readers = [_client(cluster, i, f"NReader{i}", bind=False) for i in range(3)]
        for c in posters + readers:
            await c.connect()
        seen = []
        try:
            for round_ in range(4):
                for i, poster in enumerate(posters):
                    noreply = round_ % 2 == 0  # noreply and acknowledged posts in turn
                    await poster.post("WB1", f"{tag}.P", f"{i}-{round_}", noreply=noreply)
                    await poster.ping()  # the post is in (one connection's order)
                    for reader in (readers[i], readers[(i + 1) % 3]):
                        spec = RetrieveSpec(whiteboard="WB1", pattern=f"{tag}.*", latest=0)
                        got = await reader.retrieve(spec, to="AIRCentral")
                        seen.append({m.content for m in got})
        finally:
            for c in posters + readers:
                await c.close()
        return seen

    seen = iter(run_in(cluster.client_ns, body()))
    acknowledged: set[str] = set()
    here: dict[int, set[str]] = {i: set() for i in range(3)}
    for round_ in range(4):
        for i in range(3):
            posted = f"{i}-{round_}"
            here[i].add(posted)
            if round_ % 2:
                acknowledged.add(posted)
            own, other = next(seen), next(seen)
            missing = (here[i] | acknowledged) - own
            assert not missing, f"node {i} after {posted}: {sorted(missing)} not read"
            missing = acknowledged - other
            assert not missing, f"node {(i + 1) % 3} after {posted}: {sorted(missing)} not read"


def test_a_message_to_a_module_on_another_node_reaches_it(cluster: Cluster) -> None:
    """OA-CLU-8: a message addressed to a module bound to another node is delivered there,
    unchanged, and acknowledged RECEIVE_ACCEPT by the module's name; a name bound nowhere
    gets FORWARD_FAILED from every node (OA-SESS-21)."""
    tag = "Direct.T" + secrets.token_hex(3)
    target = "Target" + secrets.token_hex(3)

    async def body() -> tuple[list[str], list[tuple[str, str, str, float | None]], list[str]]:
        receiver = _client(cluster, 2, target)
        senders = [_client(cluster, i, f"DSender{i}", bind=False) for i in range(3)]
        await receiver.connect()
        for s in senders:
            await s.connect()
        acks, got, refused = [], [], []
        try:
            # At once: the heartbeats (0.5 s apart) may not name the new binding yet.
            for i, sender in enumerate(senders):
                msg = sender.message(target, f"{tag}.M", f"from {i}", priority=2.5)
                reply = await sender.request(msg)
                acks.append(f"{reply.type} {reply.sender}")
                event = await receiver.next_message(timeout=10)
                assert event is not None, f"nothing delivered for sender {i}"
                m = event.message
                got.append((m.type, m.content, m.sender, m.priority))
                nowhere = sender.message(target + "X", f"{tag}.N", "lost")
                refused.append((await sender.request(nowhere)).type)
            # noreply (OA-MSG-15): delivered there, and no reply here before the PING's.
            first = await _noreply_then_ping(cluster, 0, Message(
                type=f"{tag}.Q", sender="DQuiet", to=target, content="quiet", noreply=True
            ))  # fmt: skip
            event = await receiver.next_message(timeout=10)
            assert event is not None and event.message.content == "quiet"
            assert first == "PING_SUCCESS", f"a reply to a noreply message came first: {first}"
        finally:
            for m in (receiver, *senders):
                await m.close()
        return acks, got, refused

    acks, got, refused = run_in(cluster.client_ns, body())
    assert acks == [f"RECEIVE_ACCEPT {target}"] * 3
    assert got == [(f"{tag}.M", f"from {i}", f"DSender{i}", 2.5) for i in range(3)]
    assert refused == ["FORWARD_FAILED"] * 3


async def _noreply_then_ping(cluster: Cluster, index: int, msg: Message) -> str:
    """Send `msg` and a PING on one raw connection to node `index`; the type of the first reply."""
    node = cluster.nodes[index]
    reader, writer = await asyncio.open_connection(node.address, 10000)
    try:
        ping = Message(type="PING", sender=msg.sender, to="CNS")
        writer.write(encode_frame(to_frame(msg)) + encode_frame(to_frame(ping)))
        frames = FrameReader()
        while (frame := frames.next_frame()) is None:
            data = await asyncio.wait_for(reader.read(65536), 10)
            assert data, "the node closed the connection"
            frames.feed(data)
        return from_frame(frame).type
    finally:
        writer.close()
