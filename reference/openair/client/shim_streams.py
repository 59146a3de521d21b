"""The stream commands of the Python binding's conformance shim (PROTOCOL.md, "Streams").

`StreamCommands` turns the optional `stream-*`, `await-sample`, `alarms-subscribe` and
`await-alarm` commands of `openair-shim/1` into calls of the client's stream API
(`Module.stream`, `Module.subscribe_stream`, `Module.next_sample`, `Module.alarms`). Payloads
travel as base64, or as `{"fill", "size"}` so that a scenario can ask for a sample of several MiB
without sending it on the shim's input. Like the rest of the shim it only translates: every
decision is the library's.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
from collections.abc import Awaitable, Callable
from typing import Any

from openair.client.module import ALARM_PATTERN, Module
from openair.client.stream_push import AlarmSubscription, StreamSubscription
from openair.client.stream_wire import ReceivedSample, StreamAlarm, StreamInfo
from openair.client.streams import StreamHandle
from openair.protocol.datasample import DataSample
from openair.protocol.errors import ApiMisuseError, ConnectionClosedError

__all__ = [
    "StreamCommands",
    "alarm_object",
    "decode_b64",
    "info_object",
    "payload_of",
    "received_object",
    "sample_object",
]

Json = dict[str, Any]
_MAX_FILL = 64 * 1024 * 1024  # the largest payload a command may ask for (max-frame-binary)


def decode_b64(text: object) -> bytes:
    """Decode standard base64 (padding required); API_MISUSE when it is not."""
    if not isinstance(text, str):
        raise ApiMisuseError("base64 text expected")
    try:
        return base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as exc:
        raise ApiMisuseError(f"not base64: {exc}") from exc


def payload_of(spec: object) -> bytes:
    """Return the payload a command describes: base64 text, or `{"fill": B, "size": N}`."""
    if isinstance(spec, dict):
        unit = decode_b64(spec.get("fill", ""))
        size = spec.get("size")
        if not isinstance(size, int) or isinstance(size, bool) or not 0 <= size <= _MAX_FILL:
            raise ApiMisuseError(f"a fill size must be an integer in 0..{_MAX_FILL}")
        if size and not unit:
            raise ApiMisuseError("a fill needs at least one byte")
        return (unit * (size // len(unit) + 1))[:size] if size else b""
    return decode_b64(spec if spec is not None else "")


def _params(raw: object) -> dict[str, str]:
    if raw is None:
        return {}
    if not isinstance(raw, list) or not all(isinstance(p, list) and len(p) == 2 for p in raw):
        raise ApiMisuseError("params must be a list of [key, value] pairs")
    return {str(k): str(v) for k, v in raw}


def _natural(value: int | None) -> int | None:
    return value if value is not None and value >= 0 else None


def sample_object(sample: DataSample, *, payloads: bool = True) -> Json:
    """Return a sample as the protocol's sample object."""
    return {
        "id": _natural(sample.id),
        "timestamp": _natural(sample.timestamp_ms),
        "size": sample.size,
        "payload": base64.b64encode(sample.payload).decode("ascii") if payloads else None,
        "params": [[k, v] for k, v in sample.params],
    }


def received_object(got: ReceivedSample, *, payloads: bool = True) -> Json:
    """Return a pushed sample as the protocol's received-sample object."""
    return {
        "stream": got.stream,
        "sample": sample_object(got.sample, payloads=payloads),
        "dropped": got.dropped,
        "received_ns": got.received_ns,
    }


def info_object(info: StreamInfo) -> Json:
    """Return a `<streaminfo>` as the protocol's info object."""
    return {
        "name": info.name,
        "whiteboard": info.whiteboard,
        "type": info.type,
        "count": info.count,
        "size": info.size,
        "oldest": info.oldest,
        "newest": info.newest,
        "maxsize": info.maxsize,
        "maxcount": info.maxcount,
        "subscribers": info.subscribers,
        "locked": info.locked,
    }


def alarm_object(alarm: StreamAlarm) -> Json:
    """Return an alarm as the protocol's alarm object."""
    return {"kind": alarm.kind, "stream": alarm.stream, "entries": dict(alarm.entries)}


def _int(command: Json, key: str, default: int | None = None) -> int:
    value = command.get(key, default)
    if not isinstance(value, int) or isinstance(value, bool):
        raise ApiMisuseError(f"{key} must be an integer")
    return value


def _optional_int(command: Json, key: str) -> int | None:
    return None if command.get(key) is None else _int(command, key)


def _seconds(command: Json) -> float:
    return max(0, _int(command, "timeout_ms", 5000)) / 1000


class StreamCommands:
    """The stream side of one shim session; `commands` maps command names to handlers."""

    def __init__(self, module: Callable[[], Module]) -> None:
        self._module = module
        self._subscriptions: dict[int, StreamSubscription] = {}
        self._alarms: dict[int, AlarmSubscription] = {}
        self._next_handle = 1
        self.commands: dict[str, Callable[[Json], Awaitable[Json]]] = {
            "stream-open": self.open,
            "stream-add": self.add,
            "stream-add-many": self.add_many,
            "stream-read": self.read,
            "stream-wait": self.wait,
            "stream-info": self.info,
            "stream-search": self.search,
            "stream-lock": self.lock,
            "stream-unlock": self.unlock,
            "stream-subscribe": self.subscribe,
            "stream-next": self.next,
            "stream-unsubscribe": self.unsubscribe,
            "await-sample": self.await_sample,
            "alarms-subscribe": self.alarms_subscribe,
            "await-alarm": self.await_alarm,
        }

    def _handle(self, command: Json) -> StreamHandle:
        target = command.get("stream")
        if not isinstance(target, str) or not target:
            raise ApiMisuseError("stream must name a stream or a stream type")
        return self._module().stream(target)

    def _new_handle(self) -> int:
        handle, self._next_handle = self._next_handle, self._next_handle + 1
        return handle

    async def open(self, command: Json) -> Json:
        """Open the handle's connection; answer the stream's name (GET_NAME)."""
        return {"name": await self._handle(command).name()}

    async def add(self, command: Json) -> Json:
        """Add one sample: ADD_SAMPLE, a BinaryM frame, or ADD_SAMPLE without waiting."""
        handle = self._handle(command)
        payload = payload_of(command.get("payload"))
        params = _params(command.get("params"))
        stamp, seq = _optional_int(command, "timestamp_ms"), _optional_int(command, "sample_seq")
        mode = command.get("mode", "message")
        if mode == "binary":
            sample_id: int | None = await handle.add_binary(
                payload, params, timestamp_ms=stamp, seq=seq
            )
        elif mode in ("message", "noreply"):
            sample_id = await handle.add(
                payload, params, noreply=mode == "noreply", timestamp_ms=stamp, seq=seq
            )
        else:
            raise ApiMisuseError(f"unknown add mode {mode!r}")
        return {"sample_id": sample_id}

    async def add_many(self, command: Json) -> Json:
        """Add several samples: one ADD_SAMPLES (batch), or pipelined ADD_SAMPLEs."""
        handle = self._handle(command)
        rows = command.get("samples")
        if not isinstance(rows, list) or not rows or not all(isinstance(r, dict) for r in rows):
            raise ApiMisuseError("samples must be a non-empty list of sample objects")
        mode = command.get("mode", "batch")
        if mode == "batch":
            samples = [
                DataSample(payload=payload_of(r.get("payload"))).with_params(
                    {**_params(r.get("params")), **_builtins(r)}
                )
                for r in rows
            ]
            return {"sample_ids": await handle.add_many(samples)}
        if mode != "pipelined":
            raise ApiMisuseError(f"unknown add-many mode {mode!r}")
        futures = [
            await handle.submit(
                payload_of(r.get("payload")),
                _params(r.get("params")),
                timestamp_ms=_optional_int(r, "timestamp_ms"),
                seq=_optional_int(r, "sample_seq"),
            )
            for r in rows
        ]
        return {"sample_ids": list(await asyncio.gather(*futures))}

    async def read(self, command: Json) -> Json:
        """Read by id, time, range, newest or oldest; answer the samples."""
        handle = self._handle(command)
        by = command.get("by")
        if by == "range":
            found = await handle.between(_int(command, "from_ms"), _int(command, "until_ms"))
        elif by == "id":
            found = [await handle.get(_int(command, "id"))]
        elif by == "time":
            found = [await handle.at(_int(command, "time_ms"))]
        elif by == "newest":
            found = [await handle.newest()]
        elif by == "oldest":
            found = [await handle.oldest()]
        else:
            raise ApiMisuseError(f"unknown read {by!r}")
        payloads = bool(command.get("payloads", True))
        return {"samples": [sample_object(s, payloads=payloads) for s in found]}

    async def wait(self, command: Json) -> Json:
        """Wait for a sample after an id or a time; answer it, or null on timeout."""
        handle = self._handle(command)
        timeout_ms = _int(command, "timeout_ms", 5000)
        last = bool(command.get("last", False))
        if (command.get("after_id") is None) == (command.get("after_ms") is None):
            raise ApiMisuseError("stream-wait takes exactly one of after_id and after_ms")
        if command.get("after_id") is not None:
            got = await handle.wait_after_id(_int(command, "after_id"), timeout_ms, last)
        else:
            got = await handle.wait_sample(_int(command, "after_ms"), timeout_ms, last)
        payloads = bool(command.get("payloads", True))
        return {"sample": None if got is None else sample_object(got, payloads=payloads)}

    async def info(self, command: Json) -> Json:
        """Answer the stream's `<streaminfo>`."""
        return {"info": info_object(await self._handle(command).info())}

    async def search(self, command: Json) -> Json:
        """SEARCH_SAMPLES; answer the samples, oldest first."""
        globs = command.get("params") or {}
        if not isinstance(globs, dict):
            raise ApiMisuseError("search params must be an object of key: glob")
        found = await self._handle(command).search(
            after=_optional_int(command, "after_ms"),
            until=_optional_int(command, "until_ms"),
            params={str(k): str(v) for k, v in globs.items()},
            latest=_int(command, "latest", 0),
        )
        payloads = bool(command.get("payloads", True))
        return {"samples": [sample_object(s, payloads=payloads) for s in found]}

    async def lock(self, command: Json) -> Json:
        """LOCK_SAMPLES; answer the lock id."""
        got = await self._handle(command).lock(_int(command, "first"), _int(command, "last"))
        return {"lock": got.lock_id}

    async def unlock(self, command: Json) -> Json:
        """UNLOCK_SAMPLES on the handle's connection."""
        await self._handle(command).unlock(_int(command, "lock"))
        return {}

    async def subscribe(self, command: Json) -> Json:
        """Open a push subscription (confirmed by the server's subscriber count)."""
        target = self._handle(command).target
        sub = self._module().subscribe_stream(target, buffer=_int(command, "buffer", 100))
        await sub.open()
        handle = self._new_handle()
        self._subscriptions[handle] = sub
        return {"subscription": handle}

    def _subscription(self, command: Json) -> StreamSubscription:
        sub = self._subscriptions.get(_int(command, "subscription"))
        if sub is None:
            raise ApiMisuseError("no such subscription")
        return sub

    async def next(self, command: Json) -> Json:
        """Answer the next pushed sample; CONNECTION_CLOSED once the subscription has ended."""
        sub = self._subscription(command)
        got = await sub.next(_seconds(command))
        if got is None:
            if not sub.active:
                raise ConnectionClosedError("the push connection has ended")
            raise TimeoutError("no sample within the timeout")
        return {"received": received_object(got, payloads=bool(command.get("payloads", True)))}

    async def unsubscribe(self, command: Json) -> Json:
        """Close a push subscription; answer what it received and what the server dropped."""
        sub = self._subscription(command)
        del self._subscriptions[_int(command, "subscription")]
        await sub.close()
        return {"received": sub.received, "dropped": sub.dropped}

    async def await_sample(self, command: Json) -> Json:
        """Answer the next sample delivered through the registration (OA-STREAM-14)."""
        got = await self._module().next_sample(_seconds(command))
        if got is None:
            raise TimeoutError("no sample within the timeout")
        return {"received": received_object(got, payloads=bool(command.get("payloads", True)))}

    async def alarms_subscribe(self, command: Json) -> Json:
        """Subscribe to stream alarms (a companion registration); answer its handle."""
        pattern = command.get("pattern") or ALARM_PATTERN
        sub = self._module().alarms(str(pattern), whiteboard=str(command.get("whiteboard", "")))
        await sub.open()
        handle = self._new_handle()
        self._alarms[handle] = sub
        return {"subscription": handle}

    async def await_alarm(self, command: Json) -> Json:
        """Answer the next alarm of an alarm subscription."""
        sub = self._alarms.get(_int(command, "subscription"))
        if sub is None:
            raise ApiMisuseError("no such alarm subscription")
        alarm = await sub.next(_seconds(command))
        if alarm is None:
            raise TimeoutError("no alarm within the timeout")
        return {"alarm": alarm_object(alarm)}


def _builtins(row: Json) -> dict[str, str]:
    """`builtin:timestamp` and `builtin:seq` of a sample row, when given."""
    out: dict[str, str] = {}
    stamp, seq = _optional_int(row, "timestamp_ms"), _optional_int(row, "sample_seq")
    if stamp is not None:
        out["builtin:timestamp"] = str(stamp)
    if seq is not None:
        out["builtin:seq"] = str(seq)
    return out
