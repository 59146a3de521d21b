"""Support for the conformance engine tests: a fake server, a server thread, a recording reporter.

`FakeServer` is a deliberately small OpenAIR server with its own framing and XML
code (it shares nothing with the suite, so a bug cannot hide on both sides); it can also
misbehave on purpose (`faults`) and play a legacy server (`legacy=True`), which the engine tests
use to see FAIL and NOT_APPLICABLE verdicts end to end.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import re
import struct
import time
import uuid
from dataclasses import dataclass, field
from typing import TypeVar
from xml.sax.saxutils import escape, quoteattr

from lxml import etree
from server_thread import ServerThread  # noqa: F401 (re-exported)

from openair_conformance.model import Event

T = TypeVar("T")

_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
_HEADER = struct.Struct("<7sxI")
WHITEBOARDS = ("AIRCentral", "WB1", "WB2")


# -- the fake server ---------------------------------------------------------------------------


def _slot(root: etree._Element, name: str) -> str:
    for child in root:
        if isinstance(child.tag, str) and child.tag.lower() == name.lower():
            return child.text or ""
    return ""


def _content(root: etree._Element) -> tuple[str, list[etree._Element]]:
    """Return (text, elements) of the <content> slot."""
    for child in root:
        if isinstance(child.tag, str) and child.tag.lower() == "content":
            return child.text or "", [c for c in child if isinstance(c.tag, str)]
    return "", []


def _reply(
    type_: str, *, sender: str, to: str, isresponse: str, content: str = "", xml: bool = False
) -> bytes:
    now = time.time()
    body = content if xml else escape(content)
    return (
        f"<message><type>{type_}</type><id>{uuid.uuid4()}</id><from>{escape(sender)}</from>"
        f"<to>{escape(to)}</to><cc></cc><stored></stored>"
        f"<isresponse>{escape(isresponse)}</isresponse>"
        f'<postedTime sec="{int(now)}" msec="{int(now * 1000) % 1000}"/>'
        f'<content language="{"xml" if xml else ""}">{body}</content></message>'
    ).encode()


def _frame(xml: bytes, tag: bytes = b"Message") -> bytes:
    return _HEADER.pack(tag, len(xml)) + xml


def _pattern_matches(pattern: str, type_: str) -> bool:
    if pattern.endswith(".*") and pattern[:-2].lower() == type_.lower():
        return True
    regex = ".*".join(re.escape(part) for part in pattern.split("*"))
    return re.fullmatch(regex, type_, re.IGNORECASE) is not None


class _Conn:
    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer
        self.acks: asyncio.Queue[etree._Element] = asyncio.Queue()

    async def read(self) -> tuple[bytes, bytes] | None:
        try:
            header = await self.reader.readexactly(12)
            tag, length = _HEADER.unpack(header)
            return tag.rstrip(b"\0"), await self.reader.readexactly(length)
        except (asyncio.IncompleteReadError, ConnectionError):
            return None

    async def send(self, xml: bytes) -> None:
        self.writer.write(_frame(xml))
        await self.writer.drain()


@dataclass
class _Module:
    name: str
    host: str
    port: int
    callback: _Conn | None = None
    triggers: list[tuple[str, str]] = field(default_factory=list)  # (pattern, whiteboard)
    registered: bool = False
    queue: asyncio.Queue[bytes] = field(default_factory=asyncio.Queue)
    task: asyncio.Task[None] | None = None


class FakeServer:
    """A small OpenAIR server (see the module docstring). Faults: {"ping_isresponse"}."""

    def __init__(self, *, legacy: bool = False, faults: frozenset[str] = frozenset()) -> None:
        self.legacy = legacy
        self.faults = faults
        self.port = 0
        self._server: asyncio.Server | None = None
        self._modules: dict[str, _Module] = {}
        self._boards: dict[str, list[etree._Element]] = {wb: [] for wb in WHITEBOARDS}
        self._wbid = itertools.count(1)
        self._ports = itertools.count(10999)  # a new listening port per BIND (OA-SESS-3)
        self._conns: list[_Conn] = []
        self._tasks: list[asyncio.Task[None]] = []

    async def start(self) -> FakeServer:
        self._server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        self.port = int(self._server.sockets[0].getsockname()[1])
        return self

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
        for conn in self._conns:
            conn.writer.close()
        tasks = [*self._tasks, *(m.task for m in self._modules.values() if m.task is not None)]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        conn = _Conn(reader, writer)
        self._conns.append(conn)
        callback = False
        while (frame := await conn.read()) is not None:
            tag, xml = frame
            try:
                root = etree.fromstring(xml, _PARSER)
            except etree.XMLSyntaxError as exc:
                await conn.send(
                    _reply(
                        "RECEIVE_ERROR",
                        sender="CNS",
                        to="",
                        isresponse="",
                        content=f"XML_MALFORMED: {exc}",
                    )
                )
                continue
            if tag == b"Receive":
                callback = True
                self._callback(conn, _slot(root, "from"))
            elif callback:
                conn.acks.put_nowait(root)
            else:
                await conn.send(self._handle(root, conn))

    def _callback(self, conn: _Conn, name: str) -> None:
        module = self._modules.get(name)
        if module is not None:
            module.callback = conn

    def _handle(self, root: etree._Element, conn: _Conn) -> bytes:
        type_, to, sender, rid = (_slot(root, s) for s in ("type", "to", "from", "id"))
        if type_ == "PING":
            wrong = "ping_isresponse" in self.faults
            return _reply(
                "PING_SUCCESS",
                sender=to or "CNS",
                to=sender,
                isresponse="nonsense" if wrong else rid,
            )
        if type_ == "KEEPALIVE":
            return _reply("KEEPALIVESUCCESS", sender=to, to=sender, isresponse=rid)
        if to in ("", "CNS"):
            return self._cns(root, conn, type_, sender, rid)
        if to in self._boards:
            return self._whiteboard(root, to, type_, sender, rid)
        return _reply(
            "FORWARD_FAILED",
            sender="CNS",
            to=sender,
            isresponse=rid,
            content=f"Could not forward message to: {to}",
        )

    def _cns(self, root: etree._Element, conn: _Conn, type_: str, sender: str, rid: str) -> bytes:
        text, elements = _content(root)
        if type_ in ("BIND", "BIND_NOLISTEN"):
            port = -1 if type_ == "BIND_NOLISTEN" else 0
            if elements and elements[0].get("port"):
                port = int(elements[0].get("port", "0"))
            host = conn.writer.get_extra_info("peername")[0]
            self._modules[sender] = _Module(name=sender, host=host, port=port)
            return _reply(
                "BIND_ACCEPT",
                sender="CNS",
                to=sender,
                isresponse=rid,
                content=str(port if port else next(self._ports)),
            )
        if type_ == "RESOLVE_REQUEST":
            if text.strip() in (*WHITEBOARDS, "CNS"):
                loc = f'<tcplocation address="127.0.0.1" port="{self.port}" name="{text.strip()}"/>'
                return _reply(
                    "RESOLVE_SUCCESS",
                    sender="CNS",
                    to=sender,
                    isresponse=rid,
                    content=loc,
                    xml=True,
                )
            return _reply("RESOLVE_FAILED", sender="CNS", to=sender, isresponse=rid)
        if type_ == "GET_CAPABILITIES" and not self.legacy:
            caps = (
                '<capabilities protocol="OpenAIR/1.0" server="fake/0">'
                '<extension name="pipelining"/><limit name="max-in-flight" value="256"/>'
                "</capabilities>"
            )
            return _reply(
                "CAPABILITIES", sender="CNS", to=sender, isresponse=rid, content=caps, xml=True
            )
        return _reply(
            "UNKNOWN_COMMAND",
            sender="CNS",
            to=sender,
            isresponse=rid,
            content=f"Offending cmd: {type_}",
        )

    def _whiteboard(
        self, root: etree._Element, wb: str, type_: str, sender: str, rid: str
    ) -> bytes:
        if type_ == "AIR.Subscribe":
            module = self._modules.setdefault(sender, _Module(name=sender, host="", port=0))
            _, elements = _content(root)
            module.triggers = [
                (t.get("type", ""), t.get("from", ""))
                for group in elements
                for t in group.iter("trigger")
            ]
            module.registered = True
            return _reply("RECEIVE_ACCEPT", sender=wb, to=sender, isresponse=rid)
        if type_ == "AIR.Retrieve":
            return self._retrieve(root, wb, sender, rid)
        self._post(root, wb)
        return _reply("RECEIVE_ACCEPT", sender=wb, to=sender, isresponse=rid)

    def _retrieve(self, root: etree._Element, wb: str, sender: str, rid: str) -> bytes:
        _, elements = _content(root)
        spec = elements[0]
        latest_el = spec.find("latest")
        latest = (
            int(latest_el.text or "1") if latest_el is not None else int(spec.get("latest", "1"))
        )
        board = self._boards.get(spec.get("from", wb), [])
        found = [
            m for m in reversed(board) if _pattern_matches(spec.get("type", "*"), _slot(m, "type"))
        ]
        found = found if latest == 0 else found[:latest]
        body = "".join(f"<object>{etree.tostring(m).decode()}</object>" for m in found)
        return _reply(
            "AIR.Retrieve.Success",
            sender=wb,
            to=sender,
            isresponse=rid,
            content=f"<objectcollection>{body}</objectcollection>",
            xml=True,
        )

    def _post(self, root: etree._Element, wb: str) -> None:
        now = time.time()
        for name, text in (("stored", wb), ("wbid", f"{next(self._wbid):08d}")):
            for old in [c for c in root if isinstance(c.tag, str) and c.tag.lower() == name]:
                root.remove(old)
            etree.SubElement(root, name).text = text
        received = etree.SubElement(root, "receivedTime")
        received.set("sec", str(int(now)))
        received.set("msec", str(int(now * 1000) % 1000))
        self._boards[wb].append(root)
        stored = etree.tostring(root).decode()
        cc = {n.strip() for n in _slot(root, "cc").split(";") if n.strip()}
        for module in self._modules.values():
            fired = self._fired(module, root, wb)
            if fired is not None or (module.name in cc and module.port):
                self._deliver(module, wb, stored, fired or "")

    def _fired(self, module: _Module, root: etree._Element, wb: str) -> str | None:
        if _slot(root, "from") == module.name:
            return None
        for pattern, board in module.triggers:
            if board.lower() in ("", "any", "*", wb.lower()) and _pattern_matches(
                pattern, _slot(root, "type")
            ):
                return pattern
        return None

    def _deliver(self, module: _Module, wb: str, stored: str, lasttrigger: str) -> None:
        phase = (
            f'<phase name="Default Phase" module={quoteattr(module.name)} '
            f'context="Psyclone.System.Ready" lasttrigger={quoteattr(lasttrigger)}>'
            "<triggers/></phase>"
        )
        content = (
            '<objectdictionary><object name="TriggerMessage">' + stored + "</object>"
            '<object name="RetrievedMessages"><objectcollection/></object>'
            f'<object name="PhaseSpec">{phase}</object></objectdictionary>'
        )
        wakeup = _reply(
            "AIR.Instruct.Wakeup",
            sender=wb,
            to=module.name,
            isresponse="",
            content=content,
            xml=True,
        ).replace(b"<stored></stored>", f"<stored>{wb}</stored>".encode())
        module.queue.put_nowait(wakeup)
        if module.task is None:
            module.task = asyncio.create_task(self._delivery_loop(module))

    async def _delivery_loop(self, module: _Module) -> None:
        outgoing: _Conn | None = None
        while True:
            wakeup = await module.queue.get()
            conn = module.callback
            if conn is None:
                if outgoing is None:
                    reader, writer = await asyncio.open_connection(module.host, module.port)
                    outgoing = _Conn(reader, writer)
                    self._conns.append(outgoing)
                    self._tasks.append(asyncio.create_task(self._read_acks(outgoing)))
                conn = outgoing
            await conn.send(wakeup)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(conn.acks.get(), 5.0)

    async def _read_acks(self, conn: _Conn) -> None:
        while (frame := await conn.read()) is not None:
            conn.acks.put_nowait(etree.fromstring(frame[1], _PARSER))


# -- running a server in a background thread ---------------------------------------------------


class Recorder:
    """A reporter that keeps every event (and counts close calls)."""

    def __init__(self) -> None:
        self.events: list[Event] = []
        self.closed = 0

    def handle(self, event: Event) -> None:
        self.events.append(event)

    def close(self) -> None:
        self.closed += 1
