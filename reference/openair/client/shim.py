"""The Python binding's conformance shim: `openair conform-client` drives `Module` through it.

Run as `python -m openair.client.shim`. It speaks `openair-shim/1`
(conformance/openair_conformance/shim/PROTOCOL.md): one JSON command per line on standard input,
one JSON answer per line on standard output, flushed after each line; logging goes to standard
error. The first line it writes is the ready event. Commands run one at a time, but the event
loop keeps running between them, so deliveries are received and acknowledged while the kit
prepares its next command.

The shim only translates: every decision (what to declare, how to acknowledge, when to stamp
postedTime) is the library's, which is what the kit judges.
"""

from __future__ import annotations

import asyncio
import base64
import json
import logging
import sys
from collections.abc import Awaitable, Callable
from importlib import metadata
from typing import Any

from openair.client.module import Module, WakeupEvent
from openair.client.session import CLIENT_EXTENSIONS
from openair.client.shim_streams import StreamCommands, decode_b64
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.errors import ApiMisuseError, OpenAIRError
from openair.protocol.message import Message
from openair.protocol.times import AirTime

__all__ = [
    "LIBRARY",
    "PROTOCOL",
    "Shim",
    "error_code",
    "main",
    "message_object",
    "wakeup_object",
]

PROTOCOL = "openair-shim/1"
LIBRARY = "openair-python"
_MAX_LINE = 16 * 1024 * 1024

Json = dict[str, Any]
Writer = Callable[[Json], None]


def _version() -> str:
    try:
        return metadata.version("openair-kit")
    except metadata.PackageNotFoundError:
        return "0.0.0"


def _time(value: AirTime | None) -> list[int] | None:
    return None if value is None else [value.sec, value.msec]


def message_object(msg: Message) -> Json:
    """Return a message as the protocol's message object."""
    return {
        "type": msg.type,
        "id": msg.id,
        "from": msg.sender,
        "to": msg.to,
        "cc": msg.cc,
        "stored": msg.stored,
        "isresponse": msg.isresponse,
        "posted": _time(msg.posted),
        "received": _time(msg.received),
        "priority": msg.priority,
        "wbid": msg.wbid,
        "content": msg.content,
        "xml": msg.content_is_xml,
        "attachments": [base64.b64encode(chunk).decode("ascii") for chunk in msg.binary],
    }


def wakeup_object(event: WakeupEvent) -> Json:
    """Return a wakeup as the protocol's wakeup object.

    The Python client does not tell which connection carried a delivery, so `path` is
    `unknown` (the protocol allows it).
    """
    wakeup = event.wakeup
    return {
        "message": message_object(event.message),
        "trigger": None if wakeup.trigger is None else message_object(wakeup.trigger),
        "retrieved": [message_object(m) for m in wakeup.retrieved],
        "lasttrigger": wakeup.lasttrigger,
        "received_ns": event.received_ns,
        "path": "unknown",
    }


def error_code(exc: BaseException) -> str:
    """Return the error-table condition that names `exc` (PROTOCOL.md, "Answers")."""
    if isinstance(exc, OpenAIRError):
        return exc.name
    if isinstance(exc, TimeoutError):
        return "REQUEST_TIMEOUT"
    if isinstance(exc, OSError):
        return "CONNECTION_CLOSED"  # refused, reset: the connection is not there
    return "API_MISUSE"  # a command the shim could not turn into a call


def _retrieve_spec(spec: Json) -> RetrieveSpec:
    lastmsec = spec.get("lastmsec")
    return RetrieveSpec(
        whiteboard=str(spec.get("whiteboard", "")),
        pattern=str(spec.get("type", "")),
        sender=str(spec.get("sender", "")),
        content=str(spec.get("content", "")),
        latest=int(spec.get("latest", 1)),
        lastmsec=None if lastmsec is None else int(lastmsec),
    )


def _trigger(spec: Json) -> Trigger:
    return Trigger(
        pattern=str(spec["type"]),
        whiteboard=str(spec.get("from", "")),
        after_ms=int(spec.get("after", 0)),
    )


class Shim:
    """One library session driven by commands; `handle` answers one command."""

    def __init__(self) -> None:
        self.module: Module | None = None
        self.closed = False
        self._commands: dict[str, Callable[[Json], Awaitable[Json]]] = {
            "connect": self.connect,
            "register": self.register,
            "post": self.post,
            "post-noreply": self.post_noreply,
            "retrieve": self.retrieve,
            "await-wakeup": self.await_wakeup,
            "close": self.close,
        }
        self.streams = StreamCommands(self._module)
        self._commands.update(self.streams.commands)  # PROTOCOL.md, "Streams"

    async def handle(self, command: Json) -> Json:
        """Run one command and return its answer (success fields, or the error)."""
        seq = command.get("seq", 0)
        action = self._commands.get(str(command.get("cmd")))
        try:
            if action is None:
                raise ApiMisuseError(f"unknown command {command.get('cmd')!r}")
            fields = await action(command)
        except Exception as exc:
            detail = exc.detail if isinstance(exc, OpenAIRError) else str(exc)
            message = detail or type(exc).__name__
            return {"seq": seq, "ok": False, "error": {"code": error_code(exc), "message": message}}
        return {"seq": seq, "ok": True, **fields}

    def _module(self) -> Module:
        if self.module is None:
            raise ApiMisuseError("connect first")
        return self.module

    async def connect(self, command: Json) -> Json:
        """Create the Module and connect it; answer the bound port and whether it is legacy."""
        if self.module is not None:
            raise ApiMisuseError("already connected")
        wanted = command.get("extensions")
        offered = CLIENT_EXTENSIONS if wanted is None else frozenset(map(str, wanted))
        module = Module(
            str(command["name"]),
            str(command["host"]),
            int(command["port"]),
            bind=bool(command.get("bind", True)),
            listen=bool(command.get("listen", True)),
            callback=bool(command.get("callback", True)),
            extensions=offered & CLIENT_EXTENSIONS,  # the library declares only what it has
        )
        await module.connect()  # closes itself when it fails: a later connect may try again
        self.module = module
        port = module.bound_port
        return {
            "bound_port": port if port is not None and port > 0 else -1,
            "legacy": module.legacy,
        }

    async def register(self, command: Json) -> Json:
        """Replace the registration (Module.subscribe)."""
        await self._module().subscribe(
            [_trigger(t) for t in command.get("triggers", [])],
            [_retrieve_spec(r) for r in command.get("retrieves", [])],
            allow_self_triggering=bool(command.get("allowselftriggering", False)),
            streams=[str(s) for s in command.get("streams", [])],  # OA-STREAM-14
        )
        return {}

    async def _post(self, command: Json, *, noreply: bool) -> Json:
        cc = command.get("cc", [])
        priority = command.get("priority")
        attachments = command.get("attachments") or []
        if not isinstance(attachments, list):
            raise ApiMisuseError("attachments must be a list of base64 strings")
        sent = await self._module().post(
            str(command["to"]),
            str(command["type"]),
            str(command.get("content", "")),
            cc=[str(name) for name in cc],
            priority=None if priority is None else float(priority),
            content_is_xml=bool(command.get("xml", False)),
            noreply=noreply,
            binary=[decode_b64(chunk) for chunk in attachments],
        )
        return {"id": sent.id}

    async def post(self, command: Json) -> Json:
        """Post and wait for RECEIVE_ACCEPT; answer the id."""
        return await self._post(command, noreply=False)

    async def post_noreply(self, command: Json) -> Json:
        """Post without waiting (noreply only if the server advertised it); answer the id."""
        return await self._post(command, noreply=True)

    async def retrieve(self, command: Json) -> Json:
        """Retrieve (one spec: AIR.Retrieve, several: AIR.Retrieves); answer newest first."""
        specs = [_retrieve_spec(s) for s in command.get("specs", [])]
        if not specs:
            raise ApiMisuseError("retrieve needs at least one spec")
        found = await self._module().retrieve(
            specs[0] if len(specs) == 1 else specs, to=str(command.get("to", "AIRCentral"))
        )
        return {"messages": [message_object(m) for m in found]}

    async def await_wakeup(self, command: Json) -> Json:
        """Answer the next wakeup, or REQUEST_TIMEOUT after timeout_ms."""
        module = self._module()
        event = await module.next_wakeup(int(command.get("timeout_ms", 5000)) / 1000)
        if event is None:
            raise TimeoutError(f"no wakeup within {command.get('timeout_ms', 5000)} ms")
        return {"wakeup": wakeup_object(event)}

    async def close(self, command: Json) -> Json:
        """Close the module; the shim exits after answering."""
        self.closed = True
        if self.module is not None:
            await self.module.close()
        return {}


def _write_stdout(line: Json) -> None:
    sys.stdout.write(json.dumps(line) + "\n")
    sys.stdout.flush()


async def _stdin_reader() -> asyncio.StreamReader:
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=_MAX_LINE)
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    return reader


async def serve(reader: asyncio.StreamReader, write: Writer = _write_stdout) -> int:
    """Say ready, then answer commands until `close` or end of input; return the exit code."""
    shim = Shim()
    write({"event": "ready", "protocol": PROTOCOL, "library": LIBRARY, "version": _version()})
    try:
        while not shim.closed:
            raw = await reader.readline()
            if not raw:
                break  # end of input means close (PROTOCOL.md)
            try:
                command = json.loads(raw)
            except ValueError as exc:
                print(f"shim: not a JSON command: {exc}", file=sys.stderr)
                continue
            if not isinstance(command, dict):
                print("shim: a command must be a JSON object", file=sys.stderr)
                continue  # OA-GEN-5: no answer, it could not be paired with a command
            seq = command.get("seq")
            if not isinstance(seq, int) or isinstance(seq, bool) or seq < 0:
                print(f"shim: a command needs a non-negative integer seq: {raw!r}", file=sys.stderr)
                continue  # OA-GEN-5
            write(await shim.handle(command))
    finally:
        if shim.module is not None:
            await shim.module.close()
    return 0


async def _main() -> int:
    return await serve(await _stdin_reader())


def main() -> int:
    """Run the shim on standard input and output."""
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    return asyncio.run(_main())


if __name__ == "__main__":
    sys.exit(main())
