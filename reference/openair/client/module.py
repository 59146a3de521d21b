"""The async OpenAIR module: connect, bind, register, post, retrieve, receive wakeups.

`Module` is an async context manager over one primary connection (its requests: `Requests`,
requests.py) and the module's delivery side (`listener.py`: its listening port and its callback
connection). It works against a server with extensions and against a legacy server (Psyclone
1.1.7): it asks GET_CAPABILITIES first and treats UNKNOWN_COMMAND as legacy (OA-CAP-2),
declaring extensions only to a server that advertised them (OA-GEN-2, OA-SESS-19). No threads:
everything runs as tasks of the caller's loop.

Connecting follows JavaOpenAIR: primary connection, BIND (or BIND_NOLISTEN), listen on the port of
BIND_ACCEPT, open the callback connection (RECEIVE_NAME_NOTIFICATION), post
`Psyclone.Module.Connect.<name>` to AIRCentral. When the primary connection is lost the module
reconnects with backoff, binds again, re-sends its last registration and posts
`Psyclone.Module.Reconnect.<name>`, as JavaOpenAIR's maintenance thread does.
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import logging
import ssl
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterable
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING, TypeVar

from openair.client.auth import check_secure, prove_on_link, prove_on_streams
from openair.client.link import Link
from openair.client.listener import Listener, Prover
from openair.client.requests import AIRCENTRAL as AIRCENTRAL
from openair.client.requests import CNS as CNS
from openair.client.requests import FailedReplyError as FailedReplyError
from openair.client.requests import Requests, _expect
from openair.client.session import CLIENT_EXTENSIONS, DEFAULT_MAX_IN_FLIGHT, ClientConnection
from openair.client.stream_wire import ReceivedSample, StreamInfo, received_sample
from openair.protocol.content import (
    Registration,
)
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    OpenAIRError,
)
from openair.protocol.message import Message
from openair.protocol.objects import (
    Capabilities,
    parse_capabilities,
)
from openair.protocol.types import is_valid_type, validate_pattern
from openair.protocol.wakeup import Wakeup, parse_wakeup

if TYPE_CHECKING:  # stream_push.py and streams.py import this module
    from openair.client.stream_push import AlarmSubscription, ModuleStreams, StreamSubscription
    from openair.client.streams import StreamHandle

log = logging.getLogger("openair.client")

WAKEUP_TYPE = "AIR.Instruct.Wakeup"
DATASAMPLE_TYPE = "DATASAMPLE"
ALARM_PATTERN = "AIR.Stream.Alarm.*"

_E = TypeVar("_E")


@dataclass(frozen=True, slots=True, kw_only=True)
class WakeupEvent:
    """A wakeup delivered to the module; `received_ns` was read from the clock on arrival.

    A phase update (Psyclone sends one after each AIR.Subscribe) has `wakeup.trigger` None.
    """

    wakeup: Wakeup
    message: Message
    received_ns: int


@dataclass(frozen=True, slots=True, kw_only=True)
class MessageEvent:
    """Any other message delivered to the module (forwarded to it by name, OA-SESS-22)."""

    message: Message
    received_ns: int


WakeupCallback = Callable[[WakeupEvent], Awaitable[None] | None]
MessageCallback = Callable[[MessageEvent], Awaitable[None] | None]
SampleCallback = Callable[[ReceivedSample], Awaitable[None] | None]


class Module(Requests):
    """An OpenAIR module (or, with `bind=False`, a plain client) connected to one server.

    `listen=False` binds with BIND_NOLISTEN and takes deliveries over the callback connection
    only (OA-SESS-5, OA-DELIV-10). `extensions=None` declares every extension this client
    implements that the server advertises; a legacy server gets no extension (OA-CAP-2).
    `request_timeout` bounds each request (OA-SESS-27: at least 10 s is advised). With
    `reconnect`, a lost primary connection is re-established with exponential backoff from
    `reconnect_delay` to `reconnect_max_delay` seconds. `on_wakeup` / `on_message` receive
    deliveries instead of the `wakeups()` / `messages()` queues; `on_sample` receives the
    stream samples a registration's `inputstream` brings (OA-STREAM-14) instead of `samples()`.
    `keepalive` is the idle time after which KEEPALIVE is sent on the primary connection
    (OA-KEEP-1; None disables it). Secure mode (spec 14.3): `secret` proves the module's name on
    every connection it opens (a server without `auth` is refused, OA-AUTH-12) and `tls` (an
    `ssl.SSLContext`, e.g. `openair.client.auth.client_tls_context()`) wraps them in TLS.
    """

    def __init__(
        self,
        name: str,
        host: str = "127.0.0.1",
        port: int = 10000,
        *,
        listen: bool = True,
        callback: bool = True,
        extensions: Iterable[str] | None = None,
        request_timeout: float | None = 10.0,
        bind: bool = True,
        announce: bool = True,
        reconnect: bool = True,
        reconnect_delay: float = 0.05,
        reconnect_max_delay: float = 2.0,
        keepalive: float | None = 60.0,
        on_wakeup: WakeupCallback | None = None,
        on_message: MessageCallback | None = None,
        on_sample: SampleCallback | None = None,
        inbox_size: int = 10000,
        now: Callable[[], int] = time.time_ns,
        secret: str | None = None,
        tls: ssl.SSLContext | None = None,
    ) -> None:
        wanted = CLIENT_EXTENSIONS if extensions is None else frozenset(extensions)
        if unknown := wanted - CLIENT_EXTENSIONS:
            raise ApiMisuseError(f"extensions this client does not implement: {sorted(unknown)}")
        if bind and not listen and not callback:
            raise ApiMisuseError("BIND_NOLISTEN needs the callback connection (OA-DELIV-10)")
        self.name = name
        self.host = host
        self.port = port
        self.request_timeout = request_timeout
        self._listen, self._callback, self._bind, self._announce = listen, callback, bind, announce
        self._wanted = wanted
        self._reconnect = reconnect
        self._delays = (reconnect_delay, reconnect_max_delay)
        self._keepalive = keepalive
        self._on_wakeup, self._on_message, self._on_sample = on_wakeup, on_message, on_sample
        self._now = now
        self._secret, self.tls = secret, tls  # secure mode (spec 14.3), TLS (OA-AUTH-10)
        self._wakeups: asyncio.Queue[WakeupEvent | None] = asyncio.Queue(inbox_size)
        self._messages: asyncio.Queue[MessageEvent | None] = asyncio.Queue(inbox_size)
        self._samples: asyncio.Queue[ReceivedSample | None] = asyncio.Queue(inbox_size)
        self._streams: ModuleStreams | None = None
        self._listener = Listener(self._deliver, name=name, now=now, on_drop=self._dropped)
        self._link: Link | None = None
        self._ready = asyncio.Event()
        self._changed = asyncio.Condition()
        self._tasks: set[asyncio.Task[None]] = set()
        self._started = self._closed = self._lost = False
        self.capabilities: Capabilities | None = None
        self.legacy = False
        self.extensions: frozenset[str] = frozenset()
        self.bound_port: int | None = None
        self.registration: Registration | None = None
        self.generation = 0
        #: Deliveries lost: inbox overflow of direct messages, and every delivery that could
        #: not be read (also counted in `undecodable_deliveries`, OA-MSG-20).
        self.dropped_messages = 0
        self.undecodable_deliveries = 0

    # -- lifecycle ---------------------------------------------------------------------------

    async def __aenter__(self) -> Module:
        await self.connect()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    @property
    def connected(self) -> bool:
        """True while the primary connection is up and set up."""
        return self._link is not None and self._ready.is_set() and not self._closed

    @property
    def session(self) -> ClientConnection | None:
        """The sans-I/O session of the primary connection (for diagnostics), if connected."""
        return self._link.conn if self._link is not None else None

    @property
    def clock(self) -> Callable[[], int]:
        """The clock the module stamps its messages with (ns since the epoch)."""
        return self._now

    @property
    def listen_port(self) -> int | None:
        """The port the module listens on for deliveries, if it listens."""
        return self._listener.port

    async def connect(self) -> None:
        """Connect, bind and start receiving; raises OSError when the server is unreachable."""
        if self._started:
            raise ApiMisuseError("connect() was already called")
        self._started = True
        try:
            await self._establish(first=True)
        except BaseException:
            await self.close()
            raise
        if self._keepalive is not None:
            self._spawn(self._keepalive_loop(self._keepalive))

    async def close(self) -> None:
        """Close every connection; later requests raise ConnectionClosedError."""
        if self._closed:
            return
        self._closed = True
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        if self._streams is not None:
            await self._streams.close()
        link, self._link = self._link, None
        if link is not None:
            await link.close()
        await self._listener.close()
        for queue in (self._wakeups, self._messages, self._samples):
            with contextlib.suppress(asyncio.QueueFull):
                queue.put_nowait(None)  # wakes a waiting consumer; a full queue drains first
        self._ready.set()

    async def wait_connected(self, generation: int = 1, timeout: float | None = None) -> None:
        """Wait until the module has (re)connected `generation` times in all."""
        async with asyncio.timeout(timeout), self._changed:
            await self._changed.wait_for(lambda: self.generation >= generation or self._closed)
        if self.generation < generation:
            raise ConnectionClosedError("the module closed before it reconnected")

    def _spawn(self, coro: Awaitable[None]) -> None:
        """Run a background task owned by this module (cancelled by close())."""
        task: asyncio.Task[None] = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _establish(self, *, first: bool) -> None:
        """Open the primary connection and set the session up (capabilities, bind, receive)."""
        link = await self.open_link(self._primary_lost)
        try:
            await self._negotiate(link)
            await self._prove(link)
            if self._bind:
                await self._bind_and_receive(link)
                if self.registration is not None:
                    await self._send_registration(link, self.registration)
                if self._announce:
                    kind = "Connect" if first else "Reconnect"
                    await self._announce_on(link, f"Psyclone.Module.{kind}.{self.name}")
        except BaseException:
            await link.close()
            raise
        self._link = link
        self._ready.set()
        async with self._changed:
            self.generation += 1
            self._changed.notify_all()

    async def _negotiate(self, link: Link) -> None:
        """Ask GET_CAPABILITIES; UNKNOWN_COMMAND (or any other answer) means legacy (OA-CAP-2)."""
        ask = Message(type="GET_CAPABILITIES", sender=self.name, to=CNS)
        _, reply = await link.request(ask, self.request_timeout)
        self.capabilities = None
        if reply.type == "CAPABILITIES":
            try:
                self.capabilities = parse_capabilities(reply.content)
            except OpenAIRError as exc:
                log.warning("unreadable CAPABILITIES, treating the server as legacy: %s", exc)
        self.legacy = self.capabilities is None
        offered = frozenset(self.capabilities.extensions) if self.capabilities else frozenset()
        self.extensions = self._wanted & offered  # OA-GEN-2
        self.configure_link(link)
        self._listener.extensions = self.extensions

    async def open_link(self, on_lost: Callable[[Link, BaseException | None], None]) -> Link:
        """Open a requester connection to the server, over TLS when the module has a context."""
        return await Link.open(
            self.host, self.port, now=self._now, name=self.name, on_lost=on_lost, tls=self.tls
        )

    async def _prove(self, link: Link) -> None:
        """With a secret, prove the name on `link` before anything acts for it (spec 14.3)."""
        if self._secret is None:
            return  # legacy mode: nothing changes on the wire
        caps = self.capabilities
        check_secure(frozenset(caps.extensions) if caps else None)  # OA-AUTH-12
        await prove_on_link(link, self.name, self._secret, self.request_timeout)

    async def open_proved_link(self, on_lost: Callable[[Link, BaseException | None], None]) -> Link:
        """Open a further requester connection, proving the name on it in secure mode."""
        link = await self.open_link(on_lost)
        try:
            await self._prove(link)
        except BaseException:
            await link.close()
            raise
        return link

    def prover(self) -> Prover | None:
        """Return what proves the name on a callback or push connection, or None (legacy)."""
        secret, timeout = self._secret, self.request_timeout
        if secret is None:
            return None
        name = self.name

        async def prove(
            reader: asyncio.StreamReader, writer: asyncio.StreamWriter, conn: ClientConnection
        ) -> None:
            await prove_on_streams(reader, writer, conn, name, secret, timeout)

        return prove

    def configure_link(self, link: Link) -> None:
        """Give a requester connection the negotiated extensions and window (OA-SESS-17)."""
        link.conn.extensions = self.extensions
        caps = self.capabilities
        window = caps.limit("max-in-flight", DEFAULT_MAX_IN_FLIGHT) if caps else 1
        link.set_window(max(1, window) if "pipelining" in self.extensions else 1)

    def _declare(self, msg: Message) -> Message:
        """Add the `extensions` slot, only towards a server that is not legacy (OA-SESS-19)."""
        if self.legacy:
            return msg  # OA-GEN-2: a legacy server is never sent an extension's wire form
        return msg.with_extra("extensions", " ".join(sorted(self.extensions)))

    async def _bind_and_receive(self, link: Link) -> None:
        """BIND (or BIND_NOLISTEN), listen on the given port, open the callback connection."""
        kind = "BIND" if self._listen else "BIND_NOLISTEN"
        bind = self._declare(Message(type=kind, sender=self.name, to=CNS))
        sent, reply = await link.request(bind, self.request_timeout)
        _expect(sent, reply, "BIND_ACCEPT")
        try:
            port = int(reply.content.strip())  # OA-SESS-3, OA-SESS-5
        except ValueError:
            raise FailedReplyError(sent, reply) from None
        self.bound_port = port
        if self._listen and port > 0 and self._listener.port != port:
            await self._listener.stop_listening()
            await self._listener.listen(link.local_host, port)  # OA-DELIV-10
        if self._callback:
            note = self._declare(Message(type="RECEIVE_NAME_NOTIFICATION", sender=self.name))
            await self._listener.open_callback(
                self.host, self.port, note, tls=self.tls, prove=self.prover()
            )  # OA-SESS-7, OA-AUTH-6

    async def _announce_on(self, link: Link, type_: str) -> None:
        """Post a lifecycle notice to AIRCentral, as JavaOpenAIR does (spec 6.9)."""
        if not is_valid_type(type_):
            return  # a module name that cannot form a type: nothing to announce
        sent, reply = await link.request(
            Message(type=type_, sender=self.name, to=AIRCENTRAL), self.request_timeout
        )
        _expect(sent, reply, "RECEIVE_ACCEPT")

    def _primary_lost(self, link: Link, error: BaseException | None) -> None:
        """React to the loss of the primary connection: reconnect, or fail what waits."""
        if link is not self._link or self._closed:
            return
        log.info("%s: primary connection lost (%s)", self.name, error or "closed by the server")
        self._link = None
        self._ready.clear()
        if self._reconnect:
            self._spawn(self._reconnect_loop())
        else:
            self._lost = True
            self._ready.set()

    async def _reconnect_loop(self) -> None:
        """Re-establish the session with exponential backoff until it works or close()."""
        delay, max_delay = self._delays
        while not self._closed:
            await asyncio.sleep(delay)
            try:
                await self._establish(first=False)
                return
            except (OSError, OpenAIRError) as exc:
                log.info("%s: reconnect failed (%s); retrying in %.2f s", self.name, exc, delay)
                delay = min(delay * 2, max_delay)

    async def _keepalive_loop(self, interval: float) -> None:
        """Send KEEPALIVE after `interval` seconds without traffic (OA-KEEP-1)."""
        while True:
            link = self._link
            idle = time.monotonic() - link.last_traffic if link is not None else 0.0
            if link is None or idle < interval:
                await asyncio.sleep(interval - idle)
                continue
            # OA-KEEP-1: empty from and to; OA-KEEP-3: an unanswered KEEPALIVE never closes.
            with contextlib.suppress(OpenAIRError, OSError):
                await link.request(Message(type="KEEPALIVE"), None)

    # -- deliveries --------------------------------------------------------------------------

    async def _deliver(self, msg: Message, received_ns: int) -> str | None:
        """Handle one delivery; the listener answers it (OA-SESS-11, OA-DELIV-4).

        PING and KEEPALIVE get their default answers. A wakeup that cannot be read raises, and
        the listener answers RECEIVE_ERROR (OA-SESS-11).
        """
        if msg.type in ("PING", "KEEPALIVE"):
            return None
        if msg.type == WAKEUP_TYPE:
            event = WakeupEvent(wakeup=parse_wakeup(msg), message=msg, received_ns=received_ns)
            if self._on_wakeup is not None:
                await self._call(self._on_wakeup, event)
            else:
                await self._wakeups.put(event)  # a full inbox holds the acknowledgement back
            return None
        if msg.type == DATASAMPLE_TYPE:  # OA-STREAM-14: a stream this module subscribed to
            sample = received_sample(msg, received_ns)  # SAMPLE_INVALID is answered
            if self._on_sample is not None:
                await self._call(self._on_sample, sample)
            else:
                await self._samples.put(sample)  # a full inbox holds the acknowledgement back
            return None
        direct = MessageEvent(message=msg, received_ns=received_ns)
        if self._on_message is not None:
            await self._call(self._on_message, direct)
        else:
            if self._messages.full():  # nobody may be reading these: keep the newest
                self._messages.get_nowait()
                self.dropped_messages += 1
            self._messages.put_nowait(direct)
        return None

    def _dropped(self, reason: str) -> None:
        """Count a delivery that could not be read; the listener logged it (OA-MSG-20)."""
        self.undecodable_deliveries += 1
        self.dropped_messages += 1

    async def _call(self, callback: Callable[[_E], Awaitable[None] | None], event: _E) -> None:
        """Run a user callback; its failure is logged, the delivery is still acknowledged."""
        try:
            result = callback(event)
            if inspect.isawaitable(result):
                await result
        except Exception:
            log.exception("%s: delivery callback failed", self.name)

    async def next_wakeup(self, timeout: float | None = None) -> WakeupEvent | None:
        """Return the next wakeup, or None after `timeout` seconds or once the module closed."""
        return await self._next(self._wakeups, timeout)

    async def next_message(self, timeout: float | None = None) -> MessageEvent | None:
        """Return the next directly delivered message, or None (timeout or closed)."""
        return await self._next(self._messages, timeout)

    async def _next(self, queue: asyncio.Queue[_E | None], timeout: float | None) -> _E | None:
        if self._closed and queue.empty():
            return None
        try:
            async with asyncio.timeout(timeout):
                return await queue.get()
        except TimeoutError:
            return None

    async def next_sample(self, timeout: float | None = None) -> ReceivedSample | None:
        """Return the next stream sample delivered to the module, or None (timeout or closed)."""
        return await self._next(self._samples, timeout)

    async def samples(self) -> AsyncIterator[ReceivedSample]:
        """Iterate over stream samples delivered to the module (its `inputstream`s)."""
        while (sample := await self.next_sample()) is not None:
            yield sample

    async def wakeups(self) -> AsyncIterator[WakeupEvent]:
        """Iterate over wakeups as they arrive, until the module closes."""
        while (event := await self.next_wakeup()) is not None:
            yield event

    async def messages(self) -> AsyncIterator[MessageEvent]:
        """Iterate over directly delivered messages, until the module closes."""
        while (event := await self.next_message()) is not None:
            yield event

    # -- streams (stream_push.py, streams.py) ----------------------------------------------

    def _stream_side(self) -> ModuleStreams:
        if self._streams is None:
            from openair.client.stream_push import ModuleStreams  # it imports this module

            self._streams = ModuleStreams(self)
        return self._streams

    def stream(self, target: str) -> StreamHandle:
        """Return the handle of the stream named (or, typed-streams, typed) `target`."""
        return self._stream_side().stream(target)

    def subscribe_stream(
        self, target: str, *, buffer: int = 100, confirm: bool = True, pipelining: bool = False
    ) -> StreamSubscription:
        """Return a push subscription to a stream (an async iterator of ReceivedSample).

        `buffer` samples wait here unread before acknowledgements stop (the server then drops
        samples for this subscriber and reports how many, OA-STREAM-8). `pipelining` declares
        that extension on the push connection: a server may then send several samples before
        their acknowledgements (throughput over a long round trip), beyond `buffer`. `confirm`
        waits until the server counts the subscriber. Use `async with`.
        """
        side = self._stream_side()
        return side.subscribe(target, buffer=buffer, confirm=confirm, pipelining=pipelining)

    def alarms(self, pattern: str = ALARM_PATTERN, *, whiteboard: str = "") -> AlarmSubscription:
        """Return an async iterator of the stream alarms matching `pattern` (OA-XSTREAM-6)."""
        return self._stream_side().alarms(validate_pattern(pattern), whiteboard)

    async def list_streams(self) -> list[StreamInfo]:
        """Return every stream of the server, in configuration order (GET_STREAMS)."""
        return await self._stream_side().list_streams()
