"""The Module against a scripted LEGACY server that behaves like Psyclone 1.1.7 on the wire.

The fake answers GET_CAPABILITIES with UNKNOWN_COMMAND, writes its XML the way Psyclone does
(`postedTime  sec msec tzc`, no root attributes, `<content>` left out when empty, `priority="2.00"`
on stored copies; shapes copied from the Psyclone transcripts 01, 03 and 08 described in
psyclone-observed.md §3), sends a phase update after AIR.Subscribe, PINGs on the callback
connection before a delivery, then connects to the module's bound port and waits about 200 ms
before its first frame, answers strictly one request at a time and never sends RECEIVE_ERROR.
It records every violation of those legacy assumptions by the client.
"""

from __future__ import annotations

import asyncio
import socket
import uuid
from dataclasses import dataclass, field
from xml.sax.saxutils import escape, quoteattr

import pytest

from openair.client import Module
from openair.protocol.codec import from_frame
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.errors import RequestTimeoutError
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag
from openair.protocol.matching import matches
from openair.protocol.message import Message
from openair.protocol.registration import parse_registration, parse_retrieves

PSYCLONE_CONNECT_DELAY = 0.2  # Psyclone waits ~200 ms after connecting before its first frame
SERVER_LATENCY = 0.005  # time the fake takes per request: a second request would arrive in it
_SEC, _MSEC = 1795328371, 444


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def psy_message(
    type_: str,
    *,
    sender: str,
    to: str,
    isresponse: str = "",
    content: str = "",
    xml: bool = False,
    stored: str = "",
    wbid: int | None = None,
    msg_id: str | None = None,
) -> str:
    """A message in Psyclone's own XML spelling (tabs, two spaces before sec, tzc, …)."""
    root = '<message priority="2.00">' if stored else "<message>"
    lines = [
        root,
        f"\t<type>{escape(type_)}</type>",
        f"\t<id>{msg_id or uuid.uuid4()}</id>",
        f"\t<from>{escape(sender)}</from>",
        f"\t<to>{escape(to)}</to>",
        "\t<cc></cc>",
        f"\t<stored>{escape(stored)}</stored>",
        f"\t<isresponse>{isresponse}</isresponse>",
    ]
    if stored:
        lines.append("\t<netprotocol>Message</netprotocol>")
        lines.append(f"\t<wbid>{wbid or 0:08d}</wbid>")
    lines.append(f'\t<postedTime  sec="{_SEC}" msec="{_MSEC}" tzc="Greenwich_0_60" />')
    if stored:
        lines.append(f'\t<receivedTime  sec="{_SEC}" msec="{_MSEC}" tzc="Greenwich_0_60" />')
    if content:  # Psyclone leaves the whole <content> element out when it is empty
        body = content if xml else escape(content)
        lines.append(f'\t<content language="{"xml" if xml else ""}">{body}</content>')
    lines.append("</message>")
    return "\n".join(lines)


def frame_bytes(xml: str) -> bytes:
    data = xml.encode("ascii")
    return b"Message\x00" + len(data).to_bytes(4, "little") + data


def stored_xml(msg: Message, wbid: int) -> str:
    return psy_message(
        msg.type, sender=msg.sender, to=msg.to, content=msg.content, stored=msg.to,
        wbid=wbid, msg_id=msg.id,
    )  # fmt: skip


def phase_xml(module: str, lasttrigger: str, triggers: list[Trigger]) -> str:
    trig = "".join(
        f'<trigger after="0" from={quoteattr(t.whiteboard)} type={quoteattr(t.pattern)} />'
        for t in triggers
    )
    return (
        f'<phase name="Default" module="{module}" context="Psyclone.System.Ready" '
        f'lasttrigger={quoteattr(lasttrigger)} pid="{uuid.uuid4()}" priority="0.000">'
        f"<triggers>{trig}</triggers>"
        f'<activationtime  sec="{_SEC}" msec="1" tzc="Greenwich_0_60" /></phase>'
    )


def wakeup_xml(module: str, sender: str, trigger: str | None, phase: str, wid: str) -> str:
    objects = "" if trigger is None else f'<object name="TriggerMessage">{trigger}</object>'
    objects += '<object name="RetrievedMessages"><objectcollection /></object>'
    objects += f'<object name="PhaseSpec">{phase}</object>'
    return psy_message(
        "AIR.Instruct.Wakeup", sender=sender, to=module, stored=sender if trigger else "",
        content=f"<objectdictionary>{objects}</objectdictionary>", xml=True, msg_id=wid,
    ).replace('<message priority="2.00">', "<message>", 1)  # fmt: skip


async def read_frame(reader: asyncio.StreamReader, frames: FrameReader) -> Frame | None:
    while (frame := frames.next_frame()) is None:
        data = await reader.read(65536)
        if not data:
            return None
        frames.feed(data)
    return frame


@dataclass
class FakeLegacyServer:
    """A Psyclone-like server: one port for CNS and every whiteboard (requests routed by `to`)."""

    bound_port: int = field(default_factory=_free_port)
    log: list[Message] = field(default_factory=list)  # every request, in arrival order
    violations: list[str] = field(default_factory=list)
    answers: list[tuple[str, Message]] = field(default_factory=list)  # (path, module's reply)
    stored: list[Message] = field(default_factory=list)
    triggers: list[Trigger] = field(default_factory=list)
    module: str = ""
    callback: tuple[asyncio.StreamReader, asyncio.StreamWriter, FrameReader] | None = None
    listener: tuple[asyncio.StreamReader, asyncio.StreamWriter, FrameReader] | None = None

    async def start(self) -> int:
        self._deliveries: asyncio.Queue[tuple[Message | None, str]] = asyncio.Queue()
        self._server = await asyncio.start_server(self._connected, "127.0.0.1", 0)
        self._worker = asyncio.ensure_future(self._deliver_loop())
        return int(self._server.sockets[0].getsockname()[1])

    async def stop(self) -> None:
        self._worker.cancel()
        self._server.close()
        for conn in (self.callback, self.listener):
            if conn is not None:
                conn[1].close()

    async def _connected(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        frames = FrameReader(FrameLimits())
        first = await read_frame(reader, frames)
        if first is None:
            return
        if first.tag is FrameTag.RECEIVE:
            note = from_frame(first)
            self.log.append(note)
            self.callback = (reader, writer, frames)  # no reply (OA-SESS-7)
            return
        queue: asyncio.Queue[Frame | None] = asyncio.Queue()
        await queue.put(first)
        busy = [False]
        pump = asyncio.ensure_future(self._pump(reader, frames, queue, busy))
        try:
            while (frame := await queue.get()) is not None:
                busy[0] = True
                await asyncio.sleep(SERVER_LATENCY)
                reply = self._handle(from_frame(frame))
                if reply is not None:
                    writer.write(frame_bytes(reply))
                    await writer.drain()
                busy[0] = False
        finally:
            pump.cancel()
            writer.close()

    async def _pump(
        self, reader: asyncio.StreamReader, frames: FrameReader, queue: asyncio.Queue[Frame | None],
        busy: list[bool],
    ) -> None:  # fmt: skip
        while (frame := await read_frame(reader, frames)) is not None:
            if busy[0] or not queue.empty():
                self.violations.append(f"{from_frame(frame).type} sent before the last reply")
            await queue.put(frame)
        await queue.put(None)

    def _reply(self, req: Message, type_: str, content: str = "", *, xml: bool = False) -> str:
        sender = req.to or "CNS"
        return psy_message(
            type_, sender=sender, to=req.sender, isresponse=req.id, content=content, xml=xml
        )

    def _handle(self, req: Message) -> str | None:
        self.log.append(req)
        if req.type == "Legacy.Silent":
            return None  # never answered: the client must give up and reconnect
        if req.noreply:
            self.violations.append("noreply sent to a legacy server")
        if req.extra("extensions") is not None:
            self.violations.append(f"extensions slot on {req.type}")
        if req.type == "GET_CAPABILITIES":
            return self._reply(req, "UNKNOWN_COMMAND", f"Offending cmd: {req.type}")
        if req.type == "BIND":
            self.module = req.sender
            return self._reply(req, "BIND_ACCEPT", str(self.bound_port))
        if req.type == "PING":
            return self._reply(req, "PING_SUCCESS")
        if req.type == "AIR.Subscribe":
            self.triggers = list(parse_registration(req.sender, req.content).triggers)
            self._deliveries.put_nowait((None, "ContextsAndPhases"))  # Psyclone's phase update
            return self._reply(req, "RECEIVE_ACCEPT")
        if req.type == "AIR.Retrieve":
            return self._retrieve(req)
        stored = Message(type=req.type, id=req.id, sender=req.sender, to=req.to,
                         content=req.content)  # fmt: skip
        self.stored.append(stored)
        if any(matches(t.pattern, req.type) for t in self.triggers):
            self._deliveries.put_nowait((stored, req.to))
        return self._reply(req, "RECEIVE_ACCEPT")

    def _retrieve(self, req: Message) -> str:
        (spec,) = parse_retrieves(req.content)
        found = [
            (n, m) for n, m in enumerate(self.stored, 1)
            if m.to == spec.whiteboard and matches(spec.pattern or "*", m.type)
        ][::-1]  # fmt: skip
        if spec.latest:
            found = found[: spec.latest]
        objects = "".join(f"<object>{stored_xml(m, n)}</object>" for n, m in found)
        return self._reply(
            req, "AIR.Retrieve.Success", f"<objectcollection>{objects}</objectcollection>", xml=True
        )

    async def _deliver_loop(self) -> None:
        while True:
            trigger, sender = await self._deliveries.get()
            await self._ping_callback(sender)
            await self._deliver(trigger, sender)

    async def _ping_callback(self, sender: str) -> None:
        """Psyclone PINGs on the callback connection (from the sending component) first."""
        assert self.callback is not None
        reader, writer, frames = self.callback
        ping = psy_message("PING", sender=sender, to=self.module)
        writer.write(frame_bytes(ping))
        frame = await read_frame(reader, frames)
        assert frame is not None
        self.answers.append(("callback", from_frame(frame)))

    async def _deliver(self, trigger: Message | None, sender: str) -> None:
        """Connect to the module's bound port (once), wait ~200 ms, send the wakeup."""
        if self.listener is None:
            reader, writer = await asyncio.open_connection("127.0.0.1", self.bound_port)
            await asyncio.sleep(PSYCLONE_CONNECT_DELAY)
            self.listener = (reader, writer, FrameReader(FrameLimits()))
        reader, writer, frames = self.listener
        trigger_xml = None if trigger is None else stored_xml(trigger, len(self.stored))
        fired = "" if trigger is None else self.triggers[0].pattern
        phase = phase_xml(self.module, fired, self.triggers)
        wid = str(uuid.uuid4())
        writer.write(frame_bytes(wakeup_xml(self.module, sender, trigger_xml, phase, wid)))
        frame = await read_frame(reader, frames)
        assert frame is not None
        answer = from_frame(frame)
        self.answers.append(("listener", answer))
        if answer.isresponse != wid:
            self.violations.append(f"wakeup {wid} answered for {answer.isresponse!r}")


async def _scenario(fake: FakeLegacyServer, port: int) -> None:
    data_spec = RetrieveSpec(whiteboard="WB1", pattern="Legacy.Data.*", latest=2)
    async with Module("LegacyReader", port=port, keepalive=None, request_timeout=10) as reader:
        assert reader.legacy and reader.capabilities is None  # OA-CAP-2
        assert reader.extensions == frozenset()
        assert reader.bound_port == fake.bound_port == reader.listen_port
        await reader.subscribe("Legacy.Wake.*", [data_spec])
        phase_update = await reader.next_wakeup(timeout=10)
        assert phase_update is not None and phase_update.wakeup.trigger is None
        assert phase_update.message.sender == "ContextsAndPhases"

        await reader.post("WB1", "Legacy.Data.1", "one")
        batch = [reader.message("WB1", f"Legacy.Data.{n}", f"n{n}") for n in (2, 3, 4)]
        sent = await reader.post_many(batch)  # legacy: one at a time, never pipelined
        assert [m.id for m in sent] == [m.id for m in batch]
        await reader.post("WB1", "Legacy.Data.5", "five", noreply=True)  # sent plainly
        rtt = await reader.ping()  # the reply to the plain "noreply" post was consumed first
        assert rtt > 0
        found = await reader.retrieve(
            RetrieveSpec(whiteboard="WB1", pattern="Legacy.Data.*", latest=3)
        )
        assert [m.type for m in found] == ["Legacy.Data.5", "Legacy.Data.4", "Legacy.Data.3"]
        assert all(m.stored == "WB1" and m.wbid for m in found)

        async with Module("Poster", port=port, bind=False, keepalive=None) as poster:
            posted = await poster.post("WB1", "Legacy.Wake.1", "wake <1> & more")
        event = await reader.next_wakeup(timeout=10)
        assert event is not None and event.wakeup.trigger is not None
        trigger = event.wakeup.trigger
        assert (trigger.type, trigger.id, trigger.sender) == ("Legacy.Wake.1", posted.id, "Poster")
        assert trigger.content == "wake <1> & more"
        assert trigger.stored == "WB1" and trigger.received is not None
        assert event.wakeup.lasttrigger == "Legacy.Wake.*"
        assert event.message.sender == "WB1"
        assert event.received_ns > 0


def test_module_against_a_legacy_server() -> None:
    async def run() -> FakeLegacyServer:
        fake = FakeLegacyServer()
        port = await fake.start()
        try:
            await _scenario(fake, port)
        finally:
            await fake.stop()
        return fake

    fake = asyncio.run(run())
    assert fake.violations == []
    kinds = [m.type for m in fake.log]
    # Connect sequence as JavaOpenAIR's (spec 6.3, 6.9), after the capabilities probe.
    assert kinds[:4] == [
        "GET_CAPABILITIES",
        "BIND",
        "RECEIVE_NAME_NOTIFICATION",
        "Psyclone.Module.Connect.LegacyReader",
    ]
    subscribe = next(m for m in fake.log if m.type == "AIR.Subscribe")
    assert subscribe.to == "AIRCentral" and subscribe.content_is_xml
    assert [t.pattern for t in fake.triggers] == ["Legacy.Wake.*"]
    # Each delivery: PING on the callback first (answered PING_SUCCESS), then the wakeup on
    # the listening port (answered RECEIVE_ACCEPT with isresponse = the wakeup's id).
    assert [(path, m.type) for path, m in fake.answers] == [
        ("callback", "PING_SUCCESS"),
        ("listener", "RECEIVE_ACCEPT"),
        ("callback", "PING_SUCCESS"),
        ("listener", "RECEIVE_ACCEPT"),
    ]
    assert all(m.sender == "LegacyReader" for _, m in fake.answers)


def test_timeout_closes_the_connection_and_reconnects() -> None:
    async def run() -> FakeLegacyServer:
        fake = FakeLegacyServer()
        port = await fake.start()
        mod = Module("Patient", port=port, keepalive=None, request_timeout=0.3,
                     reconnect_delay=0.01)  # fmt: skip
        try:
            await mod.connect()
            await mod.subscribe("Legacy.Wake.*")
            with pytest.raises(RequestTimeoutError):
                await mod.post("WB1", "Legacy.Silent")
            await mod.wait_connected(2, timeout=10)  # OA-SESS-27: closed, then reconnected
            await mod.ping()
        finally:
            await mod.close()
            await fake.stop()
        return fake

    fake = asyncio.run(run())
    kinds = [m.type for m in fake.log]
    after = kinds[kinds.index("Legacy.Silent") + 1 :]
    # JavaOpenAIR's reconnect: bind again, re-send the registration, announce the reconnect.
    assert after == [
        "GET_CAPABILITIES",
        "BIND",
        "RECEIVE_NAME_NOTIFICATION",
        "AIR.Subscribe",
        "Psyclone.Module.Reconnect.Patient",
        "PING",
    ]
    assert fake.violations == []
