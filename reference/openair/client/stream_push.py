"""Samples and alarms pushed to the client, and the module's stream side (`ModuleStreams`).

`StreamSubscription` is one push connection (spec 11.6, OA-STREAM-8): a `Receive` frame
RECEIVE_NAME_NOTIFICATION (`to` = the stream's name or type, `from` = the module's name), after
which the server is the requester (OA-SESS-28) and sends every new sample as DATASAMPLE, one at a
time, waiting for RECEIVE_ACCEPT. Each sample is acknowledged once it is in the subscription's
local buffer (`buffer` samples): a consumer that falls behind stops the acknowledgements, and the
server then drops samples for this subscriber only and reports them in the next sample's
`dropped` slot. Nothing answers a RECEIVE_NAME_NOTIFICATION that worked, so `open()` confirms
the subscription by asking the stream's GET_INFO until its `subscribers` count has grown.

`AlarmSubscription` registers a companion module (its own name and registration, so that the
caller's registration and wakeups are untouched) with a trigger on the alarm types
(OA-XSTREAM-6) and yields each alarm as a `StreamAlarm`.

`ModuleStreams` is what `Module.stream()`, `subscribe_stream()`, `alarms()` and
`list_streams()` delegate to; it closes everything it made when the module closes.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time
from types import TracebackType

from openair.client.module import ALARM_PATTERN, CNS, Module
from openair.client.session import ClientConnection, Closed, Event, Invalid, Request, Role
from openair.client.stream_wire import (
    ReceivedSample,
    StreamAlarm,
    StreamInfo,
    alarm_of,
    is_alarm,
    received_sample,
    stream_list_of,
)
from openair.client.streams import DATASAMPLE, StreamHandle, error_from, raise_for
from openair.protocol.content import Trigger
from openair.protocol.errors import (
    ApiMisuseError,
    ConnectionClosedError,
    OpenAIRError,
    RemoteProtocolError,
    RequestTimeoutError,
)
from openair.protocol.message import Message

log = logging.getLogger("openair.client")

NOTIFICATION = "RECEIVE_NAME_NOTIFICATION"
_READ_SIZE = 65536
_CONFIRM_FIRST_DELAY = 0.001  # seconds, doubled up to _CONFIRM_MAX_DELAY while confirming
_CONFIRM_MAX_DELAY = 0.05
_companions = itertools.count(1)


class _End:
    """The end of a subscription: closed (error None), or the error that ended it."""

    def __init__(self, error: BaseException | None = None) -> None:
        self.error = error


class StreamSubscription:
    """A push subscription to one stream: an async iterator of `ReceivedSample`.

    `async with module.subscribe_stream("Audio") as sub: async for got in sub: …`; iterating
    without `async with` opens it on first use, and `close()` (or the module closing) ends it.
    The iteration ends after the buffered samples once the connection is closed; a refused
    subscription raises the error it names (StreamUnknownError).
    """

    def __init__(
        self,
        handle: StreamHandle,
        *,
        buffer: int = 100,
        confirm: bool = True,
        pipelining: bool = False,
    ) -> None:
        if buffer < 1:
            raise ApiMisuseError(f"a subscription buffer holds at least 1 sample, not {buffer}")
        self.handle = handle
        self.module = handle.module
        self.target = handle.target
        self._confirm = confirm
        self._pipelining = pipelining
        self._queue: asyncio.Queue[ReceivedSample | _End] = asyncio.Queue(buffer)
        self._task: asyncio.Task[None] | None = None
        self._started = False
        self._end: _End | None = None
        self._refused: asyncio.Future[OpenAIRError] | None = None
        self._note = Message(type=NOTIFICATION)
        #: How many samples arrived, and the total the server reported dropped.
        self.received = 0
        self.dropped = 0

    def __repr__(self) -> str:
        return f"StreamSubscription(target={self.target!r}, module={self.module.name!r})"

    async def __aenter__(self) -> StreamSubscription:
        await self.open()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    def __aiter__(self) -> StreamSubscription:
        return self

    async def __anext__(self) -> ReceivedSample:
        if not self._started:
            await self.open()
        while True:
            if self._queue.empty() and self._end is not None:
                if self._end.error is not None:
                    raise self._end.error
                raise StopAsyncIteration
            item = await self._queue.get()
            if not isinstance(item, _End):
                return item

    async def next(self, timeout: float | None = None) -> ReceivedSample | None:
        """Return the next sample, or None after `timeout` seconds or at the end."""
        try:
            async with asyncio.timeout(timeout):
                return await self.__anext__()
        except (TimeoutError, StopAsyncIteration):
            return None

    @property
    def active(self) -> bool:
        """True while the push connection is open."""
        return self._task is not None and not self._task.done()

    async def open(self) -> None:
        """Open the push connection and, with `confirm`, wait until the server counts it.

        A failure (unknown stream, lost connection) is raised here and ends the iteration.
        """
        if self._started:
            return
        self._started = True
        try:
            before = (await self.handle.info()).subscribers if self._confirm else 0
            await self._connect()
            if self._confirm:
                await self._confirmed(before)
        except BaseException:
            await self.close()
            raise

    async def _connect(self) -> None:
        """Open the connection and send the notification that makes it a push one."""
        module = self.module
        reader, writer = await asyncio.open_connection(module.host, module.port, ssl=module.tls)
        # Without `pipelining` the server sends one sample at a time (OA-DELIV-5), so `buffer`
        # bounds what waits here unread; with it, up to its max-in-flight more may be on the way.
        accepted = module.extensions - (set() if self._pipelining else {"pipelining"})
        conn = ClientConnection(
            Role.REQUESTER, now=module.clock, extensions=accepted, name=module.name
        )
        note = Message(type=NOTIFICATION, sender=module.name, to=self.target)
        if not module.legacy:  # OA-SESS-19: declare what this connection accepts
            note = note.with_extra("extensions", " ".join(sorted(accepted)))
        prove = module.prover()
        if prove is not None:  # spec 14.3: prove the name before the Receive frame (OA-AUTH-6)
            await prove(reader, writer, conn)
        writer.write(conn.send_notification(note))  # OA-STREAM-8
        self._note = note
        loop = asyncio.get_running_loop()
        self._refused = loop.create_future()
        self._task = loop.create_task(self._serve(reader, writer, conn))

    async def _confirmed(self, before: int) -> None:
        """Wait until GET_INFO counts one more subscriber, or the notification was refused."""
        refused = self._refused
        assert refused is not None
        delay = _CONFIRM_FIRST_DELAY
        timeout = self.module.request_timeout
        deadline = None if timeout is None else time.monotonic() + timeout
        while (await self.handle.info()).subscribers <= before:
            if refused.done():
                raise refused.result()
            if not self.active:
                raise ConnectionClosedError("the server closed the push connection")
            if deadline is not None and time.monotonic() > deadline:
                raise RequestTimeoutError(f"subscription to {self.target!r} not confirmed")
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(delay):
                    await asyncio.shield(refused)
            delay = min(delay * 2, _CONFIRM_MAX_DELAY)

    async def _serve(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, conn: ClientConnection
    ) -> None:
        """Answer the server's requests on the push connection until it ends."""
        end = _End()
        try:
            while True:
                data = await reader.read(_READ_SIZE)
                received_ns = time.time_ns()  # the first act on arrival
                for event in conn.receive_data(data):
                    if isinstance(event, Closed):
                        return
                    frame = await self._answer(conn, event, received_ns)
                    if frame is not None:
                        writer.write(frame)
                await writer.drain()
        except (OSError, RemoteProtocolError) as exc:
            end = _End(ConnectionClosedError(f"push connection lost: {exc}"))
        except OpenAIRError as exc:
            end = _End(exc)
        finally:
            writer.close()
            self._finish(end)

    async def _answer(self, conn: ClientConnection, event: Event, received_ns: int) -> bytes | None:
        """Queue a pushed sample, then acknowledge it; answer anything else as a module does."""
        if isinstance(event, Invalid):
            return conn.answer(event)  # OA-ERR-3: RECEIVE_ERROR, the connection stays usable
        if not isinstance(event, Request):
            return None
        msg = event.message
        if msg.isresponse or msg.type == "RECEIVE_ERROR":  # the notification was refused
            error = error_from(self._note, msg)
            if self._refused is not None and not self._refused.done():
                self._refused.set_result(error)
            raise error
        if msg.type == DATASAMPLE:
            try:
                got = received_sample(msg, received_ns)
            except OpenAIRError as exc:
                return conn.answer(event, "RECEIVE_ERROR", content=exc.wire_text())
            self.received += 1
            self.dropped += got.dropped
            await self._queue.put(got)  # a full buffer holds the acknowledgement back
        return conn.answer(event) if event.needs_answer else None

    def _finish(self, end: _End) -> None:
        """Record the end; a consumer waiting on an empty buffer is woken."""
        if self._end is None:
            self._end = end
        with contextlib.suppress(asyncio.QueueFull):
            self._queue.put_nowait(end)

    async def close(self) -> None:
        """Close the push connection; the iteration ends after the samples already here."""
        self._started = True  # a closed subscription is not opened again
        task = self._task
        if task is not None and not task.done():
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        self._finish(_End())


class AlarmSubscription:
    """Stream alarms as they are posted: an async iterator of `StreamAlarm` (OA-XSTREAM-6).

    A companion module named `<module>-alarms-<n>` registers a trigger on `pattern` (on
    `whiteboard`, default any) so that the caller's own registration is left as it is.
    """

    def __init__(self, module: Module, pattern: str = ALARM_PATTERN, whiteboard: str = "") -> None:
        self.module = module
        self.trigger = Trigger(pattern=pattern, whiteboard=whiteboard)
        self.companion = Module(
            f"{module.name}-alarms-{next(_companions)}",
            module.host,
            module.port,
            listen=False,
            announce=False,
            keepalive=None,
            request_timeout=module.request_timeout,
        )
        self._opened = False

    def __repr__(self) -> str:
        return f"AlarmSubscription(pattern={self.trigger.pattern!r}, module={self.module.name!r})"

    async def open(self) -> None:
        """Connect the companion and register the trigger (acknowledged, so in force)."""
        if not self._opened:
            self._opened = True
            await self.companion.connect()
            await self.companion.subscribe(self.trigger)

    async def close(self) -> None:
        """Disconnect the companion module."""
        self._opened = True
        await self.companion.close()

    async def __aenter__(self) -> AlarmSubscription:
        await self.open()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    def __aiter__(self) -> AlarmSubscription:
        return self

    async def __anext__(self) -> StreamAlarm:
        alarm = await self.next()
        if alarm is None:
            raise StopAsyncIteration
        return alarm

    async def next(self, timeout: float | None = None) -> StreamAlarm | None:
        """Return the next alarm, or None after `timeout` seconds or once closed."""
        await self.open()
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            event = await self.companion.next_wakeup(left)
            if event is None:
                return None
            msg = event.wakeup.trigger
            if msg is not None and is_alarm(msg):  # a phase update has no trigger
                return alarm_of(msg)


class ModuleStreams:
    """A module's stream side: its handles, push subscriptions and alarm subscriptions."""

    def __init__(self, module: Module) -> None:
        self.module = module
        self._handles: dict[str, StreamHandle] = {}
        self._subscriptions: list[StreamSubscription | AlarmSubscription] = []

    def stream(self, target: str) -> StreamHandle:
        """Return the handle of the stream named (or typed) `target`, one per target."""
        handle = self._handles.get(target)
        if handle is None:
            handle = self._handles[target] = StreamHandle(self.module, target)
        return handle

    def subscribe(
        self, target: str, *, buffer: int, confirm: bool, pipelining: bool
    ) -> StreamSubscription:
        """Make a push subscription (opened by `async with`, `open()` or iterating)."""
        handle = self.stream(target)
        sub = StreamSubscription(handle, buffer=buffer, confirm=confirm, pipelining=pipelining)
        self._subscriptions.append(sub)
        return sub

    def alarms(self, pattern: str, whiteboard: str) -> AlarmSubscription:
        """Make an alarm subscription (opened by `async with`, `open()` or iterating)."""
        sub = AlarmSubscription(self.module, pattern, whiteboard)
        self._subscriptions.append(sub)
        return sub

    async def list_streams(self) -> list[StreamInfo]:
        """Ask CNS for every stream (GET_STREAMS, OA-STREAM-16)."""
        msg = Message(type="GET_STREAMS", sender=self.module.name, to=CNS)
        reply = await self.module.request(msg)
        if reply.type != "STREAMS":
            raise_for(msg, reply)
        return stream_list_of(reply)

    async def close(self) -> None:
        """Close every subscription and handle made here."""
        subs, self._subscriptions = self._subscriptions, []
        handles, self._handles = list(self._handles.values()), {}
        for sub in subs:
            await sub.close()
        for handle in handles:
            await handle.close()
