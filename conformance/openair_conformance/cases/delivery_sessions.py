"""Conformance cases for delivery (6.6, 6.9): the address a listening port is reached at,
and the queue a session leaves behind.

The modules here are raw connections (`raw_module`) or a listener of the case's own
(`_delivery.Dropper`, with nothing to drop), so the case decides where the module is reachable
and when its session ends.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import ipaddress
import socket

from openair.protocol.connection import ANSWER_FOR
from openair.protocol.message import Message
from openair_conformance.cases._common import (
    next_request,
    raw_module,
    setup_raw_bind_subscribe,
    setup_subscribe,
    stream_module_xml,
    triggers_xml,
)
from openair_conformance.cases._delivery import Dropper, accept_for, retry_window
from openair_conformance.cases._streams import StreamClient, create_stream, sample_label
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.harness.checks import is_phase_update, wakeup_trigger_id
from openair_conformance.harness.conn import TARGET_TLS, ConnectionLost, DecodeProblem, FramedStream
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case


class _RawFrom(RawConnection):
    """A raw connection to the main port whose local end is bound to `source`."""

    def __init__(self, ctx: CaseContext, *, label: str, source: str) -> None:
        super().__init__(ctx, label=label)
        self._source = source

    async def open(self) -> None:
        """Connect from `source`; INCONCLUSIVE when that cannot be done."""
        host, port = self.address
        try:
            reader, writer = await asyncio.wait_for(
                asyncio.open_connection(
                    host, port, ssl=TARGET_TLS.get(), local_addr=(self._source, 0)
                ),
                max(self.ctx.deadline, 3.5),
            )
        except (OSError, TimeoutError) as exc:
            raise Inconclusive(f"setup: cannot connect from {self._source}: {exc}") from exc
        self.ctx.note(f"connected to {host}:{port} from {self._source}")
        self._stream = FramedStream(reader, writer, label=self.label, trace=self.ctx.trace)


def _other_loopback(ctx: CaseContext) -> str:
    """Return a loopback address other than 127.0.0.1 to connect from (NotApplicable when the
    server is not on this host's IPv4 loopback)."""
    try:
        target = ipaddress.ip_address(socket.gethostbyname(ctx.target[0]))
    except (OSError, ValueError) as exc:
        raise NotApplicable(f"the target address {ctx.target[0]!r} is not resolved: {exc}") from exc
    if not (target.version == 4 and target.is_loopback):
        raise NotApplicable(
            "the server is not on this host's loopback: the suite cannot choose the address "
            "its connections come from, so it cannot tell which address the server connects to"
        )
    return "127.0.0.2" if str(target) != "127.0.0.2" else "127.0.0.3"


async def _blocked_port(dropper: Dropper, source: str) -> tuple[socket.socket, int]:
    """Hold a port of 127.0.0.1 bound and not listening (a connection there is refused, not
    answered by someone else) and listen on the same port of `source`; a port taken on
    `source` meanwhile (a shared host) is given up for another, ten times at most."""
    for _ in range(10):
        blocker = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        blocker.bind(("127.0.0.1", 0))
        port = int(blocker.getsockname()[1])
        try:
            await dropper.listen(source, port)
        except OSError as exc:
            blocker.close()
            if exc.errno == errno.EADDRNOTAVAIL:
                raise NotApplicable(f"this host cannot listen on {source}: {exc}") from exc
            continue
        return blocker, port
    raise Inconclusive(f"setup: found no port free on both 127.0.0.1 and {source}")


@case(
    id="DELIV-015",
    title="A listening port is reached at the address the module's primary connection came from",
    section="6.6",
    requirements=("OA-DELIV-1",),
    allowed=(
        "the wakeup over a connection to the bound port at the primary connection's source "
        "address (a second loopback address, 127.0.0.2)",
    ),
)
async def port_at_primary_address(ctx: CaseContext) -> None:
    """Open the primary connection from 127.0.0.2, listen there only, BIND that port with no
    address, subscribe and post: the wakeup must come to 127.0.0.2.

    127.0.0.1 on the same port is held bound and not listening, so a connection there is
    refused. Not applicable when the server is not on this host's loopback (the suite then
    cannot choose its own address).
    Catches: a server that connects to a fixed address (127.0.0.1, its own, or the one it
    listens on) instead of where the module's primary connection came from, so that a module
    on another host is never reached on its port.
    """
    source = _other_loopback(ctx)
    name = ctx.name("A")
    dropper = Dropper(ctx, name=name, drops=0)
    blocker, port = await _blocked_port(dropper, source)
    primary = _RawFrom(ctx, label="A/primary#1", source=source)
    try:
        await primary.open()
        if primary.stream.local_host != source:
            raise Inconclusive(f"setup: the connection came from {primary.stream.local_host}")
        await setup_raw_bind_subscribe(
            primary, name, port, triggers_xml(ctx.type("Go")), echoed=True
        )
        poster = await ctx.module("P", bind=False)
        await poster.post("WB1", ctx.type("Go"), "there")
        assert poster.last_sent is not None
        got = await ctx.wait(
            dropper.arrived.get(),
            what=f"wakeup on {source}:{port}",
            expected=f"a connection to {source}:{port}, where the primary connection came from "
            "(OA-DELIV-1)",
        )
        ctx.check(
            wakeup_trigger_id(got) == poster.last_sent.id,
            f"{source}:{port} got {got.type} for {wakeup_trigger_id(got)!r}",
            expected=f"the wakeup for {poster.last_sent.id} (OA-DELIV-1)",
        )
    finally:
        await primary.close()  # nothing to close when it never opened
        blocker.close()
        await dropper.close()


@case(
    id="DELIV-016",
    title="A session that ends takes its queued deliveries with it: the next session under the "
    "name gets none of them",
    section="6.9",
    requirements=("OA-SESS-15", "OA-ERR-5"),
    allowed=(
        "the new session gets the wakeup of the post made for it, and none of the old "
        "session's (one held, two queued) within the retry window",
    ),
)
async def queue_discarded_with_session(ctx: CaseContext) -> None:
    """Hold M's first wakeup, queue two more, close M's primary connection; once the Lost
    notice is out, bind M again and post for it: only the new post's wakeup may arrive.

    The new session binds at once, within the back-off of a first retry (OA-DELIV-15), so that
    a delivery task left running for the old session would reach it.
    Catches: a server that keeps the old session's queue (or its delivery task) when the
    session ends, so that a module which starts again gets stale work it never asked for
    (OA-SESS-15 discards it; a takeover, OA-SESS-6, would keep it).
    """
    watcher = await ctx.module("Watch")
    name = ctx.name("M")
    await setup_subscribe(watcher, triggers_xml(f"Psyclone.Module.Lost.{name}", wb="AIRCentral"))
    primary, callback, receive_id = await raw_module(ctx, "M")
    poster = await ctx.module("Poster", bind=False)
    old: list[str] = []
    for n in range(3):
        await poster.post("WB1", ctx.type(f"Old{n}"), str(n), cc=name)
        assert poster.last_sent is not None
        old.append(poster.last_sent.id)
        if n == 0:  # held: the other two wait in M's queue (OA-DELIV-5)
            held = await next_request(ctx, callback, receive_id=receive_id, name=name)
            if wakeup_trigger_id(held) != old[0]:
                raise Inconclusive(f"setup: M got {held.type} first, not the cc of {old[0]}")
    await primary.close()  # the session ends (OA-SESS-15); the module is gone, so is
    await callback.close()  # its callback connection, with the held wakeup unanswered
    await watcher.expect_wakeup(what="the Lost notice of M")
    _, again, again_id = await raw_module(ctx, "M")  # the same name, a new session
    await poster.post("WB1", ctx.type("New"), "new", cc=name)
    assert poster.last_sent is not None
    new = poster.last_sent.id
    # A stale delivery would come within a retry's start bound (OA-DELIV-15) of the session's
    # end; each read stays below the reply deadline, so an absence is not a late reply.
    got = await accept_for(
        ctx,
        again,
        receive_id=again_id,
        name=name,
        seconds=ctx.deadline + ctx.server.limit("retry-deadline-ms", 1000) / 1000,
    )
    stale = [t for t in got if t in old]
    ctx.check(
        not stale,
        f"the new session of M got {len(stale)} wakeup(s) of the old session's posts",
        expected="the old session's queued and held deliveries discarded (OA-SESS-15)",
    )
    ctx.check(
        new in got,
        f"the new session of M got {got}, not the wakeup for {new}",
        expected="the cc of the post made after the new BIND (OA-ERR-5)",
    )


class _Holder:
    """A module's listening port: the first connection's deliveries are held unanswered until
    the case drops that connection; on later connections every delivery is acknowledged."""

    def __init__(self, ctx: CaseContext, *, name: str) -> None:
        self.ctx = ctx
        self.name = name
        self.first: asyncio.Queue[Message] = asyncio.Queue()
        self.later: asyncio.Queue[Message] = asyncio.Queue()
        self._server: asyncio.Server | None = None
        self._streams: list[FramedStream] = []

    async def listen(self, host: str) -> int:
        """Listen on a free port of `host`; return it."""
        self._server = await asyncio.start_server(self._accept, host, 0)
        return int(self._server.sockets[0].getsockname()[1])

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        label = f"{self.name[-1]}/listener#{len(self._streams) + 1}"
        stream = FramedStream(reader, writer, label=label, trace=self.ctx.trace)
        self._streams.append(stream)
        held = len(self._streams) == 1
        with contextlib.suppress(ConnectionLost, DecodeProblem):
            while True:
                msg = stream.decode(await stream.read_frame())
                if msg.type in ANSWER_FOR:
                    await stream.send_message(msg.reply(ANSWER_FOR[msg.type], sender=self.name))
                elif held and not is_phase_update(msg):
                    self.first.put_nowait(msg)
                else:
                    await stream.send_message(msg.reply("RECEIVE_ACCEPT", sender=self.name))
                    if not is_phase_update(msg):
                        self.later.put_nowait(msg)
        await stream.close()

    async def drop_first(self) -> None:
        """Close the first connection with its deliveries unanswered."""
        self.ctx.note("the first connection closed with its deliveries unanswered")
        await self._streams[0].close()

    async def close(self) -> None:
        """Stop listening and close every accepted connection."""
        for stream in self._streams:
            await stream.close()
        if self._server is not None:
            self._server.close()


#: The samples DELIV-017 has in flight together (three: a retry queue of two never reorders).
_LABELS = ("A", "B", "C")


@case(
    id="DELIV-017",
    title="Pushed samples in flight together when the connection closes are each retried",
    section="6.6",
    requirements=("OA-DELIV-7", "OA-DELIV-15", "OA-STREAM-14"),
    needs=("pipelining", "typed-streams"),
    allowed=(
        "samples A, B and C delivered again, on a new connection to the port, each within "
        "the retry bound after the first connection closed",
    ),
)
async def pushed_samples_retried(ctx: CaseContext) -> None:
    """A module declaring `pipelining` listens on a port and registers for a stream of the
    case's own; three samples are added and all pushed, unanswered, on one connection; the
    module closes it. The three deliveries failed together: each must be attempted again.

    Catches: a server that retries only one of several failed deliveries in flight together,
    or does not retry a pushed sample at all (OA-STREAM-14 sends them through the delivery
    path of 6.6, where OA-DELIV-7 and OA-DELIV-15 hold).
    """
    window = ctx.server.limit("max-in-flight", 256)
    if window < len(_LABELS):
        raise NotApplicable(
            f"max-in-flight is {window}: fewer than {len(_LABELS)} samples can be in flight"
        )
    raw = await ctx.raw("Creator")
    stream = await create_stream(ctx, raw, "Pushed", idle=0)
    name = ctx.name("H")
    primary = await ctx.raw("H/primary")
    holder = _Holder(ctx, name=name)
    port = await holder.listen(primary.stream.local_host)
    try:
        await setup_raw_bind_subscribe(
            primary,
            name,
            port,
            stream_module_xml(ctx, name, stream),
            extensions=("pipelining",),
        )
        writer = await StreamClient.open(ctx, stream, "Writer")
        for label in _LABELS:
            await writer.add(label.encode(), [("conf:n", label)])
            got = await ctx.wait(
                holder.first.get(),
                what=f"the push of sample {label} while the earlier ones are unanswered",
                expected=f"up to max-in-flight ({window}) deliveries in flight to a module "
                "declaring pipelining (OA-DELIV-5, OA-STREAM-14)",
            )
            if sample_label(got) != label:
                raise Inconclusive(f"setup: the module got {got.type}, not sample {label}")
        await holder.drop_first()

        async def retried() -> None:
            again: set[str] = set()
            while not again >= set(_LABELS):
                label = sample_label(await holder.later.get())
                ctx.note(f"sample {label or '(unlabelled)'} came again")
                again.add(label)

        _, retry = retry_window(ctx)
        await ctx.wait(
            retried(),
            timeout=retry,
            what="retry of each of samples A, B and C after the connection closed",
            expected="each failed delivery retried: A, B and C (OA-DELIV-7, OA-DELIV-15)",
        )
    finally:
        await holder.close()
