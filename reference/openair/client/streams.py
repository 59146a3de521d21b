"""The client side of streams: write, read, wait, search, lock, subscribe (spec section 11).

`StreamHandle` (from `Module.stream(name_or_type)`) talks to one stream over a connection of
its own, opened on first use: every media command it sends names the same stream, so that
connection's *current stream* is always that stream and `add_binary` can send bare `BinaryM`
frames on it (OA-STREAM-11). A waiting command blocks its connection until its reply
(OA-SESS-2), so each wait runs on a further connection taken from a small pool. Locks belong to
the connection that took them (OA-XSTREAM-5): a lock lives as long as the handle's connection.

Push subscriptions and alarms are in `stream_push.py`; the sans-I/O request builders and reply
readers in `stream_wire.py`.

Payloads are not copied: samples are written as the three chunk parts of
`datasample.chunk_parts` (the writer joins only parts under 16 KiB) and read as memoryview
slices of the received chunk. Do not modify a payload's buffer while the call that writes it
runs.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Generator, Iterable, Mapping
from dataclasses import replace
from types import TracebackType
from typing import NoReturn

from openair.client.link import Link
from openair.client.module import FailedReplyError, Module
from openair.client.stream_wire import (
    StreamInfo,
    TimeArg,
    add_sample_request,
    add_samples_request,
    ids_of,
    integer_of,
    lock_content,
    make_sample,
    media_request,
    range_content,
    sample_of,
    samples_of,
    search_content,
    stream_info_of,
    time_content,
    timestamp_of,
    wait_type,
)
from openair.protocol.datasample import DataSample, chunk_parts
from openair.protocol.errors import (
    ApiMisuseError,
    CommandUnknownError,
    ConnectionClosedError,
    OpenAIRError,
    SampleUnknownError,
)
from openair.protocol.message import Message

log = logging.getLogger("openair.client")

DATASAMPLE = "DATASAMPLE"
TYPED_STREAMS = "typed-streams"

Payload = bytes | bytearray | memoryview


def error_from(sent: Message, reply: Message) -> OpenAIRError:
    """Return the error a failure reply names (OA-ERR-2), else a FailedReplyError.

    `RECEIVE_ERROR SAMPLE_UNKNOWN: …` gives SampleUnknownError, `DATA_NOT_ACCEPTED
    SAMPLE_INVALID: …` SampleInvalidError, UNKNOWN_COMMAND CommandUnknownError; the reply itself
    is the error's `__cause__` (a FailedReplyError holding request and reply).
    """
    failed = FailedReplyError(sent, reply)
    cls = failed.condition  # OA-ERR-8: never a local condition
    error: OpenAIRError = failed
    if cls is not None:
        error = cls(reply.content.partition(":")[2].strip())
    elif reply.type == CommandUnknownError.reply:  # OA-SESS-20: `Offending cmd: TYPE`
        error = CommandUnknownError(reply.content)
    if error is not failed:
        error.__cause__ = failed
    return error


def raise_for(sent: Message, reply: Message) -> NoReturn:
    """Raise `error_from(sent, reply)`."""
    raise error_from(sent, reply)


def _expect(sent: Message, reply: Message, expected: str) -> Message:
    if reply.type != expected:
        raise_for(sent, reply)
    return reply


def _log_unacknowledged(future: asyncio.Future[Message]) -> None:
    """Log the outcome of a fire-and-forget write that nobody awaits."""
    if future.cancelled():
        return
    if (exc := future.exception()) is not None:
        log.warning("unacknowledged sample write failed: %s", exc)
    elif future.result().type != "DATA_ACCEPTED":
        log.warning("unacknowledged sample refused: %s", future.result().content)


class StreamHandle:
    """One stream, by name or (typed-streams) by type, as seen from `module`.

    Get it with `module.stream(target)`; it is closed with the module. Every method is a
    request answered by the stream; a failure reply raises the error it names (for example
    SampleUnknownError, StreamUnknownError, SampleInvalidError, LockUnknownError).
    """

    def __init__(self, module: Module, target: str) -> None:
        if not target:
            raise ApiMisuseError("a stream handle needs a stream name or type")
        self.module = module
        self.target = target
        #: The stream's name, learnt from NAME when the handle's connection opens.
        self.stream_name = ""
        self._link: Link | None = None
        self._opening = asyncio.Lock()
        self._idle_waits: list[Link] = []
        self._busy_waits: set[Link] = set()
        self._closed = False

    def __repr__(self) -> str:
        return f"StreamHandle(target={self.target!r}, module={self.module.name!r})"

    async def __aenter__(self) -> StreamHandle:
        await self._main()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    # -- connections -------------------------------------------------------------------------

    @property
    def _timeout(self) -> float | None:
        return self.module.request_timeout

    async def _open(self) -> Link:
        """Open a requester connection set up like the module's (window, extensions)."""
        if self._closed:
            raise ConnectionClosedError("the stream handle is closed")
        module = self.module
        link = await module.open_proved_link(_ignore_loss)  # TLS and proof in secure mode
        module.configure_link(link)
        return link

    async def _main(self) -> Link:
        """Return the handle's connection, opening it (and naming its stream) when needed."""
        async with self._opening:
            if self._link is None or self._link.closed:
                link = await self._open()
                try:
                    # Any media command makes the stream this connection's current stream.
                    ask = self._request("GET_NAME")
                    sent, reply = await link.request(ask, self._timeout)
                    self.stream_name = _expect(sent, reply, "NAME").content.strip()
                except BaseException:
                    await link.close()
                    raise
                self._link = link
            return self._link

    async def close(self) -> None:
        """Close the handle's connections (its locks are released by the server)."""
        self._closed = True
        links = [self._link, *self._idle_waits, *self._busy_waits]
        self._link, self._idle_waits = None, []
        for link in links:
            if link is not None:
                await link.close()

    def _require_typed(self, command: str) -> None:
        """Refuse a typed-streams command towards a server that does not offer it (OA-GEN-2)."""
        caps = self.module.capabilities
        if caps is None or TYPED_STREAMS not in caps.extensions:
            raise ApiMisuseError(f"{command} needs a server that advertises {TYPED_STREAMS}")

    def _request(self, type: str, content: str = "", *, xml: bool = False) -> Message:
        return media_request(self.target, self.module.name, type, content, xml=xml)

    async def _ask(self, msg: Message, expected: str, link: Link | None = None) -> Message:
        """Send `msg` on `link` (default: the handle's) and return the reply of type `expected`."""
        link = link or await self._main()
        sent, reply = await link.request(msg, self._timeout)
        return _expect(sent, reply, expected)

    # -- writing -----------------------------------------------------------------------------

    async def _write(
        self, msg: Message, samples: list[DataSample]
    ) -> tuple[Link, asyncio.Future[Message] | None]:
        """Send a sample-carrying request, its chunks written as parts (no payload copy)."""
        link = await self._main()
        chunks = [chunk_parts(sample) for sample in samples]
        future = await link.submit_parts(
            lambda conn: conn.send_request_parts(msg, chunks), self._timeout
        )
        return link, future

    async def _acknowledged(
        self, msg: Message, samples: list[DataSample], noreply: bool
    ) -> Message | None:
        """Write samples; return the reply, or None when no reply is awaited (noreply)."""
        if noreply and "noreply" in self.module.extensions:
            await self._write(replace(msg, noreply=True), samples)  # OA-MSG-15: no reply comes
            return None
        link, future = await self._write(msg, samples)
        assert future is not None  # a request without noreply is always answered
        if noreply:  # the server has no noreply (OA-GEN-2): send plainly, do not wait
            future.add_done_callback(_log_unacknowledged)
            return None
        return _expect(msg, await link.result(future, self._timeout), "DATA_ACCEPTED")

    async def add(
        self,
        payload: Payload | DataSample,
        params: Mapping[str, str] | None = None,
        *,
        noreply: bool = False,
        timestamp_ms: int | None = None,
        seq: int | None = None,
    ) -> int | None:
        """Add one sample (ADD_SAMPLE); return its id, or None with `noreply` (OA-STREAM-5).

        `timestamp_ms` sets `builtin:timestamp` (else the stream stamps the receive time,
        OA-STREAM-4); `seq` sets `builtin:seq` (gap detection, OA-XSTREAM-8).
        """
        sample = make_sample(payload, params, timestamp_ms=timestamp_ms, seq=seq)
        msg = add_sample_request(self.target, self.module.name)
        reply = await self._acknowledged(msg, [sample], noreply)
        return None if reply is None else integer_of(reply, "sample id")

    async def add_many(
        self,
        payloads: Iterable[Payload | DataSample],
        params: Mapping[str, str] | None = None,
        *,
        noreply: bool = False,
        timestamp_ms: int | None = None,
        seq: int | None = None,
    ) -> list[int]:
        """Add several samples in one ADD_SAMPLES; return their ids in order ([] with noreply).

        All or none are added (OA-STREAM-5). `seq` numbers the samples from `seq` upwards.
        """
        samples = [
            make_sample(p, params, timestamp_ms=timestamp_ms, seq=None if seq is None else seq + i)
            for i, p in enumerate(payloads)
        ]
        msg = add_samples_request(self.target, self.module.name, len(samples))
        reply = await self._acknowledged(msg, samples, noreply)
        return [] if reply is None else ids_of(reply)

    async def add_binary(
        self,
        payload: Payload | DataSample,
        params: Mapping[str, str] | None = None,
        *,
        timestamp_ms: int | None = None,
        seq: int | None = None,
    ) -> int:
        """Add one sample as a bare `BinaryM` frame (OA-STREAM-11); return its id.

        The handle's connection has this stream as its current stream (GET_NAME was its first
        request), so no XML travels with the sample.
        """
        ids = await self.submit(payload, params, timestamp_ms=timestamp_ms, seq=seq, binary=True)
        return await ids

    async def submit(
        self,
        payload: Payload | DataSample,
        params: Mapping[str, str] | None = None,
        *,
        timestamp_ms: int | None = None,
        seq: int | None = None,
        binary: bool = False,
    ) -> asyncio.Future[int]:
        """Write one sample now and return a future of its id, without waiting for the reply.

        The sample is on its way when this returns; successive calls are pipelined within the
        server's window (OA-SESS-17) and answered in order, which keeps a fast writer busy.
        `binary` sends a `BinaryM` frame (as `add_binary`), else an ADD_SAMPLE.
        """
        sample = make_sample(payload, params, timestamp_ms=timestamp_ms, seq=seq)
        if binary:
            chunk = chunk_parts(sample)
            link = await self._main()
            sent = Message(type="BinaryM", sender=self.module.name, to=self.target)
            future = await link.submit_parts(lambda conn: conn.send_binary(chunk), self._timeout)
        else:
            sent = add_sample_request(self.target, self.module.name)
            link, future = await self._write(sent, [sample])
        assert future is not None  # both are always answered
        return asyncio.ensure_future(self._sample_id(link, sent, future))

    async def _sample_id(self, link: Link, sent: Message, future: asyncio.Future[Message]) -> int:
        reply = _expect(sent, await link.result(future, self._timeout), "DATA_ACCEPTED")
        return integer_of(reply, "sample id")

    # -- reading -----------------------------------------------------------------------------

    async def _sample(self, type: str, content: str = "", *, xml: bool = False) -> DataSample:
        return sample_of(await self._ask(self._request(type, content, xml=xml), DATASAMPLE))

    async def get(self, sample_id: int) -> DataSample:
        """Return the sample with this id (SampleUnknownError when the stream lacks it)."""
        return await self._sample("GET_SAMPLE_BY_ID", str(sample_id))

    async def at(self, t: TimeArg) -> DataSample:
        """Return the sample with the greatest timestamp at or before `t` (ms or AirTime)."""
        return await self._sample("GET_SAMPLE_BY_TIME", time_content(t), xml=True)

    async def between(self, first: TimeArg, last: TimeArg) -> list[DataSample]:
        """Return the samples timestamped within [first, last], oldest first."""
        msg = self._request("GET_SAMPLES_BY_TIME", range_content(first, last), xml=True)
        return samples_of(await self._ask(msg, "DATASAMPLES"))

    async def newest(self) -> DataSample:
        """Return the newest sample (SampleUnknownError when the stream is empty)."""
        return await self._sample("GET_NEWEST_DATASAMPLE")

    async def oldest(self) -> DataSample:
        """Return the oldest sample held (SampleUnknownError when the stream is empty)."""
        return await self._sample("GET_OLDEST_DATASAMPLE")

    async def newest_timestamp(self) -> int:
        """Return the newest sample's timestamp, ms since the epoch."""
        return timestamp_of(await self._ask(self._request("GET_NEWEST_TIMESTAMP"), "TIMESTAMP"))

    async def oldest_timestamp(self) -> int:
        """Return the oldest held sample's timestamp, ms since the epoch."""
        return timestamp_of(await self._ask(self._request("GET_OLDEST_TIMESTAMP"), "TIMESTAMP"))

    async def count(self) -> int:
        """Return how many samples the stream holds."""
        return integer_of(await self._ask(self._request("GET_COUNT"), "COUNT"), "count")

    async def size(self) -> int:
        """Return the payload bytes the stream holds."""
        return integer_of(await self._ask(self._request("GET_SIZE"), "SIZE"), "size")

    async def name(self) -> str:
        """Return the stream's name (its type resolved, for a handle made from a type)."""
        return (await self._ask(self._request("GET_NAME"), "NAME")).content.strip()

    async def info(self) -> StreamInfo:
        """Return the stream's `<streaminfo>` (counts, sizes, limits, subscribers…)."""
        return stream_info_of(await self._ask(self._request("GET_INFO"), "INFO"))

    async def search(
        self,
        *,
        after: TimeArg | None = None,
        until: TimeArg | None = None,
        params: Mapping[str, str] | None = None,
        latest: int = 0,
    ) -> list[DataSample]:
        """Return the samples within [after, until] whose parameters match the globs, oldest
        first; at most the newest `latest` when it is not 0 (SEARCH_SAMPLES, OA-XSTREAM-9)."""
        self._require_typed("SEARCH_SAMPLES")
        content = search_content(after=after, until=until, params=params, latest=latest)
        msg = self._request("SEARCH_SAMPLES", content, xml=True)
        return samples_of(await self._ask(msg, "DATASAMPLES"))

    # -- waiting -----------------------------------------------------------------------------

    async def wait_after_id(
        self, sample_id: int, timeout_ms: int, last: bool = False
    ) -> DataSample | None:
        """Wait for a sample with an id greater than `sample_id`: the oldest such (the newest
        with `last`); None when `timeout_ms` passes first (WAIT_FOR_*_AFTERID, OA-STREAM-7)."""
        kind = wait_type(by_id=True, last=last, timeout_ms=timeout_ms)
        return await self._wait(self._request(kind, str(sample_id)), timeout_ms)

    async def wait_sample(
        self, t: TimeArg, timeout_ms: int, last: bool = False
    ) -> DataSample | None:
        """Wait for a sample timestamped at or after `t`: the oldest such (the newest with
        `last`); None when `timeout_ms` passes first (WAIT_FOR_*_SAMPLE, OA-STREAM-7)."""
        kind = wait_type(by_id=False, last=last, timeout_ms=timeout_ms)
        return await self._wait(self._request(kind, time_content(t), xml=True), timeout_ms)

    async def _wait(self, msg: Message, timeout_ms: int) -> DataSample | None:
        """Run a waiting command on a pooled connection of its own (it blocks it, OA-SESS-2)."""
        link = await self._wait_link()
        if self._closed:  # closed while the connection opened
            await link.close()
            raise ConnectionClosedError("the stream handle is closed")
        timeout = None if self._timeout is None else self._timeout + timeout_ms / 1000
        self._busy_waits.add(link)
        try:
            sent, reply = await link.request(msg, timeout)
        except BaseException:
            await link.close()  # a wait still pending on the server would block the next one
            raise
        finally:
            self._busy_waits.discard(link)
        if self._closed:
            await link.close()
        else:
            self._idle_waits.append(link)
        if reply.type == DATASAMPLE:
            return sample_of(reply)
        try:
            raise_for(sent, reply)
        except SampleUnknownError:
            return None  # OA-STREAM-7: the timeout passed first

    async def _wait_link(self) -> Link:
        """Take an idle wait connection that is still open, or open one."""
        while self._idle_waits:
            link = self._idle_waits.pop()
            if not link.closed:
                return link
        return await self._open()

    # -- locks -------------------------------------------------------------------------------

    def lock(self, first: int, last: int) -> PendingLock:
        """Lock the held samples with ids in [first, last] (LOCK_SAMPLES, OA-XSTREAM-5).

        `lk = await handle.lock(1, 9)` then `await lk.unlock()`, or `async with
        handle.lock(1, 9) as lk:`. The lock belongs to the handle's connection.
        """
        return PendingLock(self, first, last)

    async def _lock(self, first: int, last: int) -> StreamLock:
        self._require_typed("LOCK_SAMPLES")
        link = await self._main()
        msg = self._request("LOCK_SAMPLES", lock_content(first, last))
        lock_id = integer_of(await self._ask(msg, "LOCKED", link), "lock id")
        return StreamLock(self, link, lock_id=lock_id, first=first, last=last)

    async def unlock(self, lock_id: int) -> None:
        """Release lock `lock_id` held by this handle's connection (UNLOCK_SAMPLES).

        A lock id the connection does not hold raises LockUnknownError (OA-XSTREAM-5).
        """
        self._require_typed("UNLOCK_SAMPLES")
        await self._ask(self._request("UNLOCK_SAMPLES", str(lock_id)), "RECEIVE_ACCEPT")

    async def _unlock(self, link: Link, lock_id: int) -> None:
        if link.closed or link is not self._link:
            raise ConnectionClosedError("the lock was released with its connection")
        await self.unlock(lock_id)


def _ignore_loss(link: Link, error: BaseException | None) -> None:
    """A stream connection that is lost is reopened by the next request that needs it."""
    log.debug("stream connection lost: %s", error or "closed by the server")


class StreamLock:
    """A lock on a range of samples; `unlock()` releases it (UNLOCK_SAMPLES)."""

    def __init__(self, handle: StreamHandle, link: Link, *, lock_id: int, first: int, last: int):
        self.handle = handle
        self.lock_id = lock_id
        self.first, self.last = first, last
        self._link = link
        self.released = False

    def __repr__(self) -> str:
        return f"StreamLock(lock_id={self.lock_id}, first={self.first}, last={self.last})"

    async def unlock(self) -> None:
        """Release the lock (LockUnknownError when the server no longer knows it)."""
        if not self.released:
            await self.handle._unlock(self._link, self.lock_id)
            self.released = True

    async def __aenter__(self) -> StreamLock:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.unlock()


class PendingLock:
    """What `StreamHandle.lock` returns: await it, or use it as an async context manager."""

    def __init__(self, handle: StreamHandle, first: int, last: int) -> None:
        self._handle, self._range = handle, (first, last)
        self._lock: StreamLock | None = None

    def __await__(self) -> Generator[object, None, StreamLock]:
        return self._handle._lock(*self._range).__await__()

    async def __aenter__(self) -> StreamLock:
        self._lock = await self._handle._lock(*self._range)
        return self._lock

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._lock is not None:
            await self._lock.unlock()
