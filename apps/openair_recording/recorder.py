"""Record a running system: every routed message and every stream sample, into a file.

The recorder is an ordinary module. It asks STATUS for the whiteboards (their `whiteboards.NAME.*`
counters, OA-SESS-25) and GET_STREAMS for the streams (OA-STREAM-16), then registers one trigger
on the type pattern for any whiteboard (OA-TRIG-1; a whiteboard created later is covered too)
and an `<inputstream>` per stream (OA-STREAM-14), so wakeups and samples arrive interleaved on
its delivery path in the order the server sent them. Each wakeup's trigger message is the stored
copy (OA-WAKE-2: `stored`, both times, `wbid`, every slot) with its attachments (OA-WAKE-10).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from openair.client.module import Module, WakeupEvent
from openair.client.stream_wire import ReceivedSample
from openair.protocol.content import StreamRef, Trigger
from openair.protocol.errors import OpenAIRError
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary
from openair_recording.fileformat import Header, RecordingWriter

__all__ = ["RecordOptions", "Recorder", "whiteboard_names"]

log = logging.getLogger("openair_recording")


@dataclass(frozen=True, slots=True, kw_only=True)
class RecordOptions:
    """What to record: a type pattern, the streams (None: all), the module's name."""

    types: str = "*"
    streams: Sequence[str] | None = None
    name: str = "Recorder"
    timeout: float = 10.0


async def whiteboard_names(module: Module) -> tuple[str, ...]:
    """Ask CNS for STATUS and return the whiteboards its counters name (maybe none)."""
    request = Message(type="STATUS", sender=module.name, to="CNS")
    try:
        reply = await module.request(request)
        entries = parse_dictionary(reply.content).entries if reply.content.strip() else ()
    except OpenAIRError:  # a server without STATUS counters (Psyclone)
        return ()
    names: dict[str, None] = {}
    for key, _ in entries:
        if key.startswith("whiteboards.") and key.endswith(".count"):
            names[key[len("whiteboards.") : -len(".count")]] = None
    return tuple(names)


class Recorder:
    """One recording session: `start()` connects and subscribes, `stop()` completes the file.

    `notes` says what could not be recorded (no STATUS, no streams, unknown stream names).
    """

    def __init__(
        self,
        host: str,
        port: int,
        path: str | Path,
        options: RecordOptions | None = None,
        *,
        now: Callable[[], int] = time.time_ns,
        module_class: type[Module] = Module,
    ) -> None:
        self.host, self.port, self.path = host, port, Path(path)
        self.options = options or RecordOptions()
        self._now = now
        self.notes: list[str] = []
        self.writer: RecordingWriter | None = None
        self.module = module_class(
            self.options.name, host, port, announce=False, keepalive=None,
            request_timeout=self.options.timeout, on_wakeup=self._on_wakeup,
            on_sample=self._on_sample, now=now,
        )  # fmt: skip
        self._changed = asyncio.Event()

    @property
    def messages(self) -> int:
        return self.writer.messages if self.writer is not None else 0

    @property
    def samples(self) -> int:
        return self.writer.samples if self.writer is not None else 0

    async def start(self) -> None:
        """Connect, learn the whiteboards and streams, open the file and subscribe."""
        await self.module.connect()
        boards = await whiteboard_names(self.module)
        if not boards:
            self.notes.append("STATUS named no whiteboards: recording every whiteboard anyway")
        streams = await self._streams()
        header = Header(
            server=f"{self.host}:{self.port}", started_ns=self._now(), recorder=self.module.name,
            types=self.options.types, whiteboards=boards, streams=tuple(streams),
            extensions=tuple(sorted(self.module.extensions)),
        )  # fmt: skip
        self.writer = RecordingWriter(self.path, header)
        names = [s["name"] for s in streams]
        await self.module.subscribe(
            Trigger(pattern=self.options.types),  # any whiteboard (OA-TRIG-1)
            streams=[StreamRef(kind="inputstream", alias=n, source=n) for n in names],
        )

    async def _streams(self) -> list[dict[str, str]]:
        """Return the streams to record, as header entries (GET_STREAMS, OA-STREAM-16)."""
        wanted = self.options.streams
        if wanted is not None and not wanted:
            return []
        try:
            infos = await self.module.list_streams()
        except OpenAIRError as exc:
            self.notes.append(f"no streams recorded: GET_STREAMS failed ({exc})")
            return []
        known = {i.name: i for i in infos}
        if wanted is not None:
            for name in wanted:
                if name not in known:
                    self.notes.append(f"no stream {name!r} on the server: not recorded")
        chosen = [i for i in infos if wanted is None or i.name in wanted]
        return [
            {"name": i.name, "whiteboard": i.whiteboard, "type": i.type, "maxsize": str(i.maxsize)}
            for i in chosen
        ]

    async def _on_wakeup(self, event: WakeupEvent) -> None:
        msg = event.wakeup.trigger
        if msg is None or self.writer is None or self.writer.closed:
            return  # a phase update (no message), or too early or late
        self.writer.add_message(msg, event.received_ns)
        self._changed.set()

    async def _on_sample(self, received: ReceivedSample) -> None:
        if self.writer is None or self.writer.closed:
            return
        self.writer.add_sample(
            received.stream, received.sample, received.received_ns, received.dropped
        )
        self._changed.set()

    async def wait_for(self, messages: int, samples: int = 0) -> None:
        """Wait until at least this many messages and samples are recorded (for tests, tools)."""
        while self.messages < messages or self.samples < samples:
            self._changed.clear()
            await self._changed.wait()

    async def stop(self) -> None:
        """Close the module, then write the index and the end record."""
        await self.module.close()
        if self.writer is not None:
            self.writer.close(self._now())


async def record(
    host: str,
    port: int,
    path: str | Path,
    options: RecordOptions,
    stop: asyncio.Event,
    duration: float | None = None,
) -> Recorder:
    """Record until `stop` is set or `duration` seconds have passed; return the recorder."""
    recorder = Recorder(host, port, path, options)
    try:
        await recorder.start()
        try:
            async with asyncio.timeout(duration):
                await stop.wait()
        except TimeoutError:
            pass
    finally:
        await recorder.stop()
    return recorder
