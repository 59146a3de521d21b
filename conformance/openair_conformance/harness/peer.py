"""`TestModule`: the suite playing one module against the server under test.

A module sends every request on its primary connection to the main port (the server routes by
`to`; OA-SESS-9, OA-SESS-26), listens on its own port (any number of connections, OA-DELIV-2)
and opens the callback connection (RECEIVE_NAME_NOTIFICATION, OA-SESS-7), so that a server may
deliver over either path (OA-DELIV-1). On every connection the server uses it answers PING,
KEEPALIVE and deliveries (OA-SESS-11, OA-DELIV-4) and records which path brought each wakeup.
Phase updates (wakeups without TriggerMessage, OA-WAKE-8) are kept apart from wakeups.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.harness.checks import (
    is_phase_update,
    registered_module_name,
    triggered_by,
    wakeup_trigger_id,
)
from openair_conformance.harness.conn import (
    ConnectionLost,
    FramedStream,
    RequesterChannel,
    ResponderChannel,
    open_stream,
)
from openair_conformance.model import Fail, Inconclusive, NotApplicable

if TYPE_CHECKING:
    from openair_conformance.harness.context import CaseContext

__all__ = ["BARRIER_PRIORITY", "TestModule"]

#: Barrier sentinels are posted at the lowest priority, so that no earlier delivery queued for
#: the module can be sent after them (OA-PRIO-1: lower number first, FIFO within a priority).
BARRIER_PRIORITY = 6.999

Predicate = Callable[[Message], bool]


class TestModule:
    """One module played by the suite (see the module docstring)."""

    __test__ = False  # not a pytest test class, despite the name

    def __init__(self, ctx: CaseContext, *, suffix: str, name: str) -> None:
        self.ctx = ctx
        self.suffix = suffix
        self.name = name
        self.bound_port: int | None = None
        self.listen_port: int | None = None
        self.last_sent: Message | None = None
        self.wakeups_seen: list[Message] = []
        self.delivery_paths: list[str] = []
        self.phase_updates: list[Message] = []
        self.deliveries_seen: list[Message] = []
        self._inbox: list[Message] = []
        self._other_inbox: list[Message] = []
        self._arrived = asyncio.Event()
        self._acks = asyncio.Event()
        self._acks.set()
        self._problems: list[str] = []
        self._primary: RequesterChannel | None = None
        self._responders: list[ResponderChannel] = []
        self._servers: list[asyncio.Server] = []
        self._listener_count = 0
        self._closed = False

    # -- setup ---------------------------------------------------------------------------------

    async def open(
        self, *, listen: bool, callback: bool, bind: bool, extensions: Iterable[str]
    ) -> None:
        """Connect, and (if asked) listen, bind and open the callback connection."""
        declared = tuple(extensions)
        missing = [e for e in declared if not self.ctx.server.has(e)]
        if missing:  # OA-GEN-2: never declare what the server did not advertise
            raise NotApplicable(f"the server does not advertise {', '.join(missing)}")
        host, port = self.ctx.target
        stream = await self._connect(host, port, f"{self.suffix}/primary")
        self._primary = RequesterChannel(
            stream, name=self.name, pipelining=self.ctx.server.has("pipelining")
        )
        self._primary.start()
        if not bind:
            return
        if listen:
            self.listen_port = await self._listen(stream.local_host, 0)
            await self._bind_listening(stream.local_host, declared)
        else:
            await self._bind_nolisten(declared)
        if callback:
            await self._open_callback(host, port, declared)

    async def _connect(self, host: str, port: int, label: str) -> FramedStream:
        try:
            return await open_stream(
                host, port, label=label, trace=self.ctx.trace, timeout=self.ctx.deadline
            )
        except ConnectionLost as exc:
            raise Inconclusive(f"setup: {exc}") from exc

    async def _listen(self, host: str, port: int) -> int:
        server = await asyncio.start_server(self._accept, host, port)
        self._servers.append(server)
        bound = int(server.sockets[0].getsockname()[1])
        self.ctx.trace.note(f"listening on {host}:{bound}", f"{self.suffix}/listener")
        return bound

    def _with_extensions(self, msg: Message, declared: tuple[str, ...]) -> Message:
        # OA-SESS-19: the extensions slot; a legacy module sends none.
        return msg.with_extra("extensions", " ".join(declared)) if declared else msg

    async def _bind_listening(self, host: str, declared: tuple[str, ...]) -> None:
        """BIND asking for the port the suite already listens on (OA-SESS-4), else any port."""
        location = f'<tcplocation port="{self.listen_port}"/>'
        bind = Message(
            type="BIND",
            sender=self.name,
            to="CNS",
            content=location,
            content_is_xml=True,
            language="xml",
        )
        reply = await self.request(self._with_extensions(bind, declared))
        if reply.type == "BIND_ERROR":  # the port was refused: let the server choose
            plain = Message(type="BIND", sender=self.name, to="CNS")
            reply = await self.request(self._with_extensions(plain, declared))
        port = self._bind_port(reply, "BIND")
        self.bound_port = port
        if port != self.listen_port and port > 0:
            self.ctx.note(f"the server assigned port {port}; listening there too")
            try:
                await self._listen(host, port)
            except OSError as exc:
                raise Inconclusive(f"setup: cannot listen on assigned port {port}: {exc}") from exc

    async def _bind_nolisten(self, declared: tuple[str, ...]) -> None:
        msg = Message(type="BIND_NOLISTEN", sender=self.name, to="CNS")
        self.bound_port = self._bind_port(
            await self.request(self._with_extensions(msg, declared)), "BIND_NOLISTEN"
        )

    def _bind_port(self, reply: Message, what: str) -> int:
        if reply.type != "BIND_ACCEPT":
            raise Inconclusive(f"setup: {what} answered {reply.type} {reply.content!r}")
        try:
            return int(reply.content.strip())
        except ValueError as exc:
            raise Inconclusive(f"setup: {what} accepted with port {reply.content!r}") from exc

    async def _open_callback(self, host: str, port: int, declared: tuple[str, ...]) -> None:
        stream = await self._connect(host, port, f"{self.suffix}/callback")
        notice = self._with_extensions(
            Message(type="RECEIVE_NAME_NOTIFICATION", sender=self.name), declared
        )
        try:
            notice = await stream.send_message(notice, FrameTag.RECEIVE)  # OA-SESS-7: no reply
        except ConnectionLost as exc:
            raise Inconclusive(f"setup: callback connection: {exc}") from exc
        self._responder(stream, "callback", ignore=notice.id).start()

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._listener_count += 1
        label = f"{self.suffix}/listener#{self._listener_count}"
        peer = writer.get_extra_info("peername")
        self.ctx.trace.note(f"the server connected from {peer}", label)
        stream = FramedStream(reader, writer, label=label, trace=self.ctx.trace)
        await self._responder(stream, "listener").serve()

    def _responder(self, stream: FramedStream, path: str, *, ignore: str = "") -> ResponderChannel:
        channel = ResponderChannel(
            stream,
            name=self.name,
            path=path,
            on_delivery=self._delivered,
            on_problem=self._problem,
            gate=self._acks,
            own_request_id=ignore,
        )
        self._responders.append(channel)
        return channel

    # -- deliveries ----------------------------------------------------------------------------

    def _delivered(self, msg: Message, channel: ResponderChannel) -> None:
        if msg.type != "AIR.Instruct.Wakeup":
            self.deliveries_seen.append(msg)
            self._other_inbox.append(msg)
        elif is_phase_update(msg):
            self.phase_updates.append(msg)
        else:
            self.wakeups_seen.append(msg)
            self.delivery_paths.append(channel.path)
            self._inbox.append(msg)
            trigger_id = wakeup_trigger_id(msg)
            if trigger_id is not None:
                self.ctx.woken(trigger_id)
        self._arrived.set()

    def _problem(self, text: str) -> None:
        self._problems.append(text)
        self._arrived.set()

    def _raise_problem(self) -> None:
        if self._problems:
            self.ctx.fail(self._problems[0])

    def pause_acks(self) -> None:
        """Hold the acknowledgements of deliveries (PING and KEEPALIVE are still answered)."""
        self._acks.clear()

    def resume_acks(self) -> None:
        """Send the held acknowledgements and acknowledge at once again."""
        self._acks.set()

    # -- requests ------------------------------------------------------------------------------

    @property
    def primary(self) -> RequesterChannel:
        """The primary connection."""
        if self._primary is None:
            raise RuntimeError("module not opened")
        return self._primary

    async def request(self, msg: Message, *, timeout: float | None = None) -> Message:
        """Send a request on the primary connection and return its reply."""
        try:
            sent, future = await self.primary.send(msg)
        except ConnectionLost as exc:
            self.ctx.fail(f"cannot send {msg.type}: {exc}")
        self.last_sent = sent
        self.ctx.posted(sent.id)
        return await self.ctx.wait(future, what=f"reply to {sent.type}", timeout=timeout)

    async def send_noreply(self, msg: Message) -> None:
        """Send a message that gets no reply (noreply="yes", OA-MSG-15)."""
        try:
            self.last_sent = await self.primary.send_noreply(msg)
        except ConnectionLost as exc:
            self.ctx.fail(f"cannot send {msg.type}: {exc}")
        self.ctx.posted(self.last_sent.id)

    async def post(
        self,
        to: str,
        type: str,
        content: str = "",
        *,
        cc: str = "",
        priority: float | None = None,
        language: str = "",
        xml: bool = False,
        sender: str | None = None,
        noreply: bool = False,
        check: bool = True,
    ) -> Message:
        """Post a message; return the reply (Fail unless RECEIVE_ACCEPT, when `check`).

        With `noreply` (extension `noreply`) nothing is answered and the sent message is
        returned instead. The message as sent is also in `last_sent`. The type must carry the
        run's token (`ctx.type(...)`), unless the case is `residue` (`check_post_type`).
        """
        self.ctx.check_post_type(type)
        msg = Message(
            type=type,
            sender=self.name if sender is None else sender,
            to=to,
            cc=cc,
            priority=priority,
            content=content,
            content_is_xml=xml,
            language="xml" if xml and not language else language,
            noreply=noreply,
        )
        if noreply:
            if not self.ctx.server.has("noreply"):  # OA-GEN-2
                raise NotApplicable("the server does not advertise noreply")
            await self.send_noreply(msg)
            assert self.last_sent is not None
            return self.last_sent
        reply = await self.request(msg)
        if check and reply.type != "RECEIVE_ACCEPT":
            self.ctx.fail(
                f"the post of {type} to {to} was answered {reply.type} {reply.content!r}",
                expected="RECEIVE_ACCEPT (OA-WB-3)",
            )
        return reply

    async def subscribe(
        self,
        content_xml: str,
        *,
        to: str = "AIRCentral",
        check: bool = False,
        timeout: float | None = None,
    ) -> Message:
        """Send AIR.Subscribe with XML content; return the reply (Fail if `check` and refused;
        `timeout` replaces the deadline for a registration that takes long to read).

        A `<module name="N">` registration must name a module of this case and run (a legacy
        server takes N as the module registered, so a shared placeholder such as "x" lets
        cases register over each other): anything else is a harness error.
        """
        self.ctx.check_module_name(registered_module_name(content_xml))
        msg = Message(
            type="AIR.Subscribe",
            sender=self.name,
            to=to,
            content=content_xml,
            content_is_xml=True,
            language="xml",
        )
        reply = await self.request(msg, timeout=timeout)
        if check and reply.type != "RECEIVE_ACCEPT":
            self.ctx.fail(
                f"AIR.Subscribe was answered {reply.type} {reply.content!r}",
                expected="RECEIVE_ACCEPT (OA-REG-7)",
            )
        return reply

    async def retrieve(
        self, spec_xml: str, *, to: str = "AIRCentral", plural: bool = False
    ) -> Message:
        """Send AIR.Retrieve (or AIR.Retrieves when `plural`); return the reply."""
        msg = Message(
            type="AIR.Retrieves" if plural else "AIR.Retrieve",
            sender=self.name,
            to=to,
            content=spec_xml,
            content_is_xml=True,
            language="xml",
        )
        return await self.request(msg)

    # -- waiting for deliveries ----------------------------------------------------------------

    async def _take(self, box: list[Message], predicate: Predicate | None) -> Message:
        while True:
            self._raise_problem()
            for index, msg in enumerate(box):
                if predicate is None or predicate(msg):
                    return box.pop(index)
            self._arrived.clear()
            await self._arrived.wait()

    async def next_wakeup(self, *, timeout: float | None = None) -> Message:
        """Return the next wakeup not yet taken, from any path (Fail if none in time)."""
        return await self.expect_wakeup(timeout=timeout)

    async def expect_wakeup(
        self,
        predicate: Predicate | None = None,
        *,
        timeout: float | None = None,
        what: str = "wakeup",
    ) -> Message:
        """Return the first wakeup not yet taken that satisfies `predicate`.

        Late (after the deadline, within the grace): Timing. Later or never: Fail (OA-GEN-6).
        Wakeups that do not satisfy the predicate stay for later calls.
        """
        return await self.ctx.wait(
            self._take(self._inbox, predicate),
            what=f"{what} for {self.name}",
            timeout=timeout,
            expected=f"an AIR.Instruct.Wakeup delivered to {self.name}",
        )

    async def expect_wakeup_for(self, message_id: str, *, timeout: float | None = None) -> Message:
        """Return the wakeup whose TriggerMessage is the message with this id."""
        return await self.expect_wakeup(
            triggered_by(message_id), timeout=timeout, what=f"wakeup for message {message_id}"
        )

    async def next_delivery(self, *, timeout: float | None = None) -> Message:
        """Return the next delivery that is not a wakeup (a forwarded message, OA-SESS-22)."""
        return await self.ctx.wait(
            self._take(self._other_inbox, None), what=f"delivery to {self.name}", timeout=timeout
        )

    def pending_wakeups(self) -> list[Message]:
        """Return (without taking them) the wakeups that arrived and were not taken yet."""
        return list(self._inbox)

    async def barrier(self, whiteboard: str = "WB1") -> list[Message]:
        """Post a sentinel cc'd to this module and return the wakeups that arrived before it.

        The returned wakeups are taken; the sentinel's own wakeup is dropped. This proves the
        absence of a wakeup without sleeping, relying on OA-PRIO-1 (no earlier delivery for the
        module is sent after the sentinel, which has the lowest priority). It cannot prove the
        absence of wakeups delayed by `after`. If the sentinel never arrives the case is
        INCONCLUSIVE (Psyclone 1.1.7 wakes a cc'd module only when it has a registration,
        DEV-12).
        """
        await self.post(
            whiteboard,
            self.ctx.barrier_type(self.suffix),
            "barrier",
            cc=self.name,
            priority=BARRIER_PRIORITY,
        )
        assert self.last_sent is not None
        is_sentinel = triggered_by(self.last_sent.id)

        async def sentinel_index() -> int:
            while True:
                self._raise_problem()
                index = next((i for i, m in enumerate(self._inbox) if is_sentinel(m)), None)
                if index is not None:
                    return index
                self._arrived.clear()
                await self._arrived.wait()

        try:
            index = await self.ctx.wait(sentinel_index(), what=f"barrier wakeup for {self.name}")
        except Fail as exc:
            raise Inconclusive(f"cannot prove absence: {exc.message}") from exc
        before = self._inbox[:index]
        del self._inbox[: index + 1]
        return before

    # -- teardown ------------------------------------------------------------------------------

    async def close(self) -> None:
        """Close every connection of the module (the server then posts Module.Lost)."""
        if self._closed:
            return
        self._closed = True
        self._acks.set()  # responders waiting to acknowledge must not hang after the case
        if self._primary is not None:
            await self._primary.close()
        for server in self._servers:
            server.close()
        for channel in self._responders:
            await channel.close()
        for server in self._servers:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(server.wait_closed(), 1.0)
