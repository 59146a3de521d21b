"""The requests of an OpenAIR module: post, subscribe, retrieve, resolve, ping (spec 6-9).

`Requests` is the part of `Module` (module.py) that sends requests on the primary connection
and interprets their replies; `Module` owns the connection, its reconnection and the delivery
side. A failure reply raises `FailedReplyError` (OA-GEN-3), naming the condition (OA-ERR-8).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Iterable, Sequence
from dataclasses import replace

from openair.client.link import Link
from openair.protocol.attachments import parse_results
from openair.protocol.content import (
    Phase,
    Registration,
    RegistrationForm,
    RetrieveSpec,
    StreamRef,
    TcpLocation,
    Trigger,
)
from openair.protocol.errors import (
    ERRORS,
    ApiMisuseError,
    Blame,
    ConnectionClosedError,
    OpenAIRError,
    RequestFailedError,
    RequestTimeoutError,
)
from openair.protocol.message import Message
from openair.protocol.objects import (
    parse_tcplocation,
)
from openair.protocol.registration import encode_registration, encode_retrieve, encode_retrieves
from openair.protocol.types import validate_pattern, validate_type

log = logging.getLogger("openair.client")

AIRCENTRAL = "AIRCentral"
CNS = "CNS"


class FailedReplyError(RequestFailedError):
    """A request got a failure reply (REQUEST_FAILED, OA-GEN-3); `response` is that reply.

    `condition` is the error-table class named by a `NAME: detail` content (OA-ERR-2), or None
    when the content names no condition a peer may send (OA-ERR-7, OA-ERR-8).
    """

    def __init__(self, request: Message, response: Message) -> None:
        detail = f"{request.type} answered {response.type}"
        super().__init__(f"{detail}: {response.content}" if response.content else detail)
        self.request = request
        self.response = response

    @property
    def condition(self) -> type[OpenAIRError] | None:
        """The error condition the reply names, if it names one (OA-ERR-8)."""
        cls = ERRORS.get(self.response.content.split(":", 1)[0].strip())
        return None if cls is None or cls.blame is Blame.LOCAL else cls


def _expect(sent: Message, reply: Message, *types: str) -> Message:
    """Return `reply` when its type is one of `types`, else raise FailedReplyError."""
    if reply.type not in types:
        raise FailedReplyError(sent, reply)
    return reply


def _triggers(triggers: str | Trigger | Iterable[str | Trigger]) -> tuple[Trigger, ...]:
    """Normalise triggers: a string is a pattern on any whiteboard; patterns are validated."""
    items = (triggers,) if isinstance(triggers, (str, Trigger)) else tuple(triggers)
    out = tuple(Trigger(pattern=t) if isinstance(t, str) else t for t in items)
    for trigger in out:
        validate_pattern(trigger.pattern)  # OA-MATCH-7: refuse before the server has to
    return out


def _cc(cc: str | Iterable[str]) -> str:
    """Join cc names with `;` (OA-CC-1)."""
    return cc if isinstance(cc, str) else ";".join(cc)


def _stream_refs(streams: str | StreamRef | Iterable[str | StreamRef]) -> tuple[StreamRef, ...]:
    """Normalise stream subscriptions: a string S is `<inputstream alias=S source=S/>`."""
    items = (streams,) if isinstance(streams, (str, StreamRef)) else tuple(streams)
    return tuple(
        StreamRef(kind="inputstream", alias=s, source=s) if isinstance(s, str) else s for s in items
    )


class Requests:
    """Requests on the module's primary connection (mixed into `Module`)."""

    name: str
    request_timeout: float | None
    extensions: frozenset[str]
    registration: Registration | None
    _link: Link | None
    _ready: asyncio.Event
    _started: bool
    _closed: bool
    _lost: bool

    async def _wait_link(self) -> Link:
        """Return the primary connection, waiting while the module reconnects."""
        while True:
            if self._closed:
                raise ConnectionClosedError("the module is closed")
            if not self._started:
                raise ApiMisuseError("call connect() first")
            if self._lost:
                raise ConnectionClosedError("the connection to the server was lost")
            if self._link is not None and self._ready.is_set():
                return self._link
            await self._ready.wait()

    async def _request(self, msg: Message) -> tuple[Message, Message]:
        """Send `msg` on the primary connection; return it as sent and its reply."""
        try:
            async with asyncio.timeout(self.request_timeout):
                link = await self._wait_link()
        except TimeoutError:
            raise RequestTimeoutError(f"not connected within {self.request_timeout} s") from None
        return await link.request(msg, self.request_timeout)

    async def request(self, msg: Message) -> Message:
        """Send any request as is (postedTime stamped) and return the reply, uninterpreted."""
        return (await self._request(msg))[1]

    def message(
        self,
        to: str,
        type: str,
        content: str = "",
        *,
        cc: str | Iterable[str] = (),
        priority: float | None = None,
        language: str = "",
        content_is_xml: bool = False,
        noreply: bool = False,
        binary: Sequence[bytes] = (),
        version: str = "",
    ) -> Message:
        """Build a message from this module (type validated, OA-TYPE-1).

        `binary` are its attachments (OA-WB-13), `version` its content's version (OA-MSG-22).
        """
        return Message(
            type=validate_type(type),
            sender=self.name,
            to=to,
            cc=_cc(cc),
            priority=priority,
            language="xml" if content_is_xml and not language else language,
            content=content,
            content_is_xml=content_is_xml,
            noreply=noreply,
            binary=tuple(binary),
            content_version=version,
        )

    async def post(
        self,
        to: str,
        type: str,
        content: str = "",
        *,
        cc: str | Iterable[str] = (),
        priority: float | None = None,
        language: str = "",
        content_is_xml: bool = False,
        noreply: bool = False,
        binary: Sequence[bytes] = (),
        version: str = "",
    ) -> Message:
        """Post a message and wait for RECEIVE_ACCEPT (OA-WB-3); return it as sent.

        A failure reply raises FailedReplyError. With `noreply` nothing is awaited: under the
        `noreply` extension no reply comes (OA-WB-8); towards a server without it the message is
        sent plainly (OA-GEN-2) and its reply is read and dropped.
        """
        msg = self.message(
            to, type, content, cc=cc, priority=priority, language=language,
            content_is_xml=content_is_xml, noreply=noreply, binary=binary, version=version,
        )  # fmt: skip
        if noreply:
            return await self._post_noreply(msg)
        sent, reply = await self._request(msg)
        _expect(sent, reply, "RECEIVE_ACCEPT")
        return sent

    async def _post_noreply(self, msg: Message) -> Message:
        """Send without waiting: `noreply` when the server has it, else fire and forget."""
        link = await self._wait_link()
        if "noreply" in self.extensions:
            return await link.send_noreply(msg)
        sent, future = await link.submit(replace(msg, noreply=False), self.request_timeout)
        future.add_done_callback(_log_dropped_reply)
        return sent

    async def post_many(self, messages: Iterable[Message]) -> list[Message]:
        """Post several messages, pipelined when the server allows (OA-SESS-17); in order.

        A message without `from` gets this module's name. Every reply is awaited; the first
        failure is raised afterwards (FailedReplyError).
        """
        link = await self._wait_link()
        pending: list[tuple[Message, asyncio.Future[Message]]] = []
        for msg in messages:
            pending.append(await link.submit(replace(msg, sender=msg.sender or self.name),
                                             self.request_timeout))  # fmt: skip
        sent_all: list[Message] = []
        failure: OpenAIRError | None = None
        for sent, future in pending:
            try:
                _expect(sent, await link.result(future, self.request_timeout), "RECEIVE_ACCEPT")
            except OpenAIRError as exc:
                failure = failure or exc
            sent_all.append(sent)
        if failure is not None:
            raise failure
        return sent_all

    async def subscribe(
        self,
        triggers: str | Trigger | Iterable[str | Trigger],
        retrieves: Iterable[RetrieveSpec] = (),
        *,
        allow_self_triggering: bool = False,
        streams: str | StreamRef | Iterable[str | StreamRef] = (),
    ) -> Registration:
        """Replace this module's registration (OA-REG-1); it is re-sent after a reconnect.

        A string trigger is a pattern on any whiteboard; patterns are validated first
        (OA-MATCH-7). Sent as the `<module>` form to AIRCentral (OA-REG-3), which Psyclone
        also reads with its retrieves. `streams` subscribes to streams by name, type or type
        pattern (`<inputstream>`, OA-STREAM-14): their samples arrive through `samples()`.
        """
        phase = Phase(
            name="Default",
            triggers=_triggers(triggers),
            retrieves=tuple(retrieves),
            streams=_stream_refs(streams),
        )
        reg = Registration(
            module=self.name,
            form=RegistrationForm.MODULE,
            phases=(phase,),
            allow_self_triggering=allow_self_triggering,
        )
        await self._send_registration(await self._wait_link(), reg)
        self.registration = reg
        return reg

    async def _send_registration(self, link: Link, reg: Registration) -> None:
        """Send AIR.Subscribe and require RECEIVE_ACCEPT (OA-REG-7)."""
        msg = Message(
            type="AIR.Subscribe",
            sender=self.name,
            to=AIRCENTRAL,
            language="xml",
            content=encode_registration(reg, RegistrationForm.MODULE),
            content_is_xml=True,
        )
        sent, reply = await link.request(msg, self.request_timeout)
        _expect(sent, reply, "RECEIVE_ACCEPT")

    async def retrieve(
        self, specs: RetrieveSpec | Sequence[RetrieveSpec], *, to: str = AIRCENTRAL
    ) -> list[Message]:
        """Retrieve stored messages, newest first (OA-RET-6).

        One spec is sent as AIR.Retrieve, several as AIR.Retrieves (OA-RET-1); a spec without
        `whiteboard` reads the addressee `to` (OA-RET-2).
        """
        if isinstance(specs, RetrieveSpec):
            kind, content = "AIR.Retrieve", encode_retrieve(specs)
        else:
            kind, content = "AIR.Retrieves", encode_retrieves(specs)
        msg = Message(
            type=kind, sender=self.name, to=to, language="xml", content=content, content_is_xml=True
        )
        sent, reply = await self._request(msg)
        _expect(sent, reply, f"{kind}.Success")  # OA-RET-7
        if not reply.content.strip():
            return []
        return list(parse_results(reply))  # with their attachments (OA-RET-19)

    async def resolve(self, name: str) -> TcpLocation:
        """Ask CNS where a component listens (OA-SESS-8); RESOLVE_FAILED raises."""
        msg = Message(type="RESOLVE_REQUEST", sender=self.name, to=CNS, content=name)
        sent, reply = await self._request(msg)
        _expect(sent, reply, "RESOLVE_SUCCESS")
        return parse_tcplocation(reply.content)

    async def ping(self) -> float:
        """Send PING to CNS and return the round-trip time in seconds (OA-SESS-10)."""
        msg = Message(type="PING", sender=self.name, to=CNS)
        start = time.perf_counter()
        sent, reply = await self._request(msg)
        rtt = time.perf_counter() - start
        _expect(sent, reply, "PING_SUCCESS")
        return rtt


def _log_dropped_reply(future: asyncio.Future[Message]) -> None:
    """Log the outcome of a fire-and-forget post that nobody awaits."""
    if future.cancelled():
        return
    if (exc := future.exception()) is not None:
        log.warning("unacknowledged post failed: %s", exc)
    elif future.result().type != "RECEIVE_ACCEPT":
        log.warning("unacknowledged post refused: %s", future.result().type)
