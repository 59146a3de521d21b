"""Start a shim and speak `openair-shim/1` with it (PROTOCOL.md beside this file).

`ShimDriver` runs the shim as an asyncio subprocess, waits (bounded) for its ready line, sends
one command at a time and returns each answer after checking it: the line must be one JSON
object that `shim.schema.json` accepts, a success answer must also match the definition for its
command (`$defs/answer-<cmd>`), and its `seq` must echo the command's. Anything else raises
`ShimProtocolError`, which fails the scenario. Standard error is collected (the last
`STDERR_KEEP` bytes) for the report. Every line in and out can be observed through `on_line`
(the runner traces them).

Validation uses the `jsonschema` package, imported when the first driver starts.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import json
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

__all__ = [
    "PROTOCOL",
    "SCHEMA_PATH",
    "STDERR_KEEP",
    "STREAM_COMMANDS",
    "ShimDriver",
    "ShimError",
    "ShimInfo",
    "ShimProtocolError",
    "ShimStartError",
    "shim_schema",
    "validate_line",
]

PROTOCOL = "openair-shim/1"
SCHEMA_PATH = Path(__file__).resolve().parent / "shim.schema.json"
STDERR_KEEP = 64 * 1024
MAX_LINE = 64 * 1024 * 1024  # a retrieve answer may hold many messages
COMMANDS = frozenset(
    {"connect", "register", "post", "post-noreply", "retrieve", "await-wakeup", "close"}
)
#: The optional commands of streams (PROTOCOL.md, "Streams and attachments").
STREAM_COMMANDS = frozenset(
    {
        "stream-open",
        "stream-add",
        "stream-add-many",
        "stream-read",
        "stream-wait",
        "stream-info",
        "stream-search",
        "stream-lock",
        "stream-unlock",
        "stream-subscribe",
        "stream-next",
        "stream-unsubscribe",
        "await-sample",
        "alarms-subscribe",
        "await-alarm",
    }
)

LineObserver = Callable[[str, str], None]  # (direction "out" | "in", the line's text)


class ShimError(Exception):
    """The shim cannot be driven."""


class ShimStartError(ShimError):
    """The shim could not be started, or did not say ready in time."""


class ShimProtocolError(ShimError):
    """The shim broke `openair-shim/1`: a bad line, a wrong seq, no answer in time, or it died."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ShimInfo:
    """What the shim's ready line says."""

    library: str
    version: str
    protocol: str = PROTOCOL

    @property
    def label(self) -> str:
        """`library version`, the name reports give the binding."""
        return f"{self.library} {self.version}"


@cache
def shim_schema() -> dict[str, Any]:
    """The JSON Schema of every line a shim writes (shim.schema.json)."""
    schema: dict[str, Any] = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
    return schema


@cache
def _validator(definition: str) -> Any:
    """A Draft 2020-12 validator for the whole schema ("") or for one of its `$defs`."""
    try:  # imported by name: the kit has no stubs for it, and it is only a test extra
        jsonschema = importlib.import_module("jsonschema")
    except ImportError as exc:  # a test extra of the kit, needed at run time by conform-client
        raise ShimError("checking shim lines needs the jsonschema package") from exc
    schema = dict(shim_schema())
    if definition:
        schema.pop("oneOf")
        schema["$ref"] = f"#/$defs/{definition}"
    return jsonschema.Draft202012Validator(schema)


def validate_line(line: Any, command: str | None = None) -> list[str]:
    """Return what is wrong with a decoded line (empty when valid).

    `command` None checks the line against the whole schema; otherwise an answer to that
    command is checked against `$defs/failure` or `$defs/answer-<command>`.
    """
    if command is None:
        definition = ""
    elif isinstance(line, dict) and line.get("ok") is False:
        definition = "failure"
    else:
        definition = f"answer-{command}"
    problems = []
    for error in _validator(definition).iter_errors(line):
        where = "/".join(str(part) for part in error.absolute_path) or "(line)"
        problems.append(f"{where}: {error.message}")
    return problems


class ShimDriver:
    """One shim process: start it, command it, close it."""

    def __init__(
        self,
        argv: Sequence[str],
        *,
        on_line: LineObserver | None = None,
        env: Mapping[str, str] | None = None,
        cwd: str | Path | None = None,
    ) -> None:
        if not argv:
            raise ShimStartError("no shim command given")
        self.argv = list(argv)
        self._on_line = on_line
        self._env = None if env is None else {**os.environ, **env}
        self._cwd = cwd
        self._proc: asyncio.subprocess.Process | None = None
        self._stderr = bytearray()
        self._stderr_dropped = 0
        self._stderr_task: asyncio.Task[None] | None = None
        self._seq = 0
        self._lock = asyncio.Lock()
        self.info: ShimInfo | None = None
        self.started_at = 0.0
        self.ready_after = 0.0

    # -- life cycle ------------------------------------------------------------------------------

    async def start(self, timeout: float) -> ShimInfo:
        """Start the shim and return its ready line; ShimStartError if that fails."""
        _validator("")  # fail early when jsonschema is missing
        self.started_at = time.monotonic()
        try:
            self._proc = await asyncio.create_subprocess_exec(
                *self.argv,
                stdin=asyncio.subprocess.PIPE,
                stdout=asyncio.subprocess.PIPE,
                stderr=asyncio.subprocess.PIPE,
                env=self._env,
                cwd=self._cwd,
                limit=MAX_LINE,
            )
        except OSError as exc:
            raise ShimStartError(f"cannot start {self.argv[0]!r}: {exc}") from exc
        assert self._proc.stderr is not None
        self._stderr_task = asyncio.create_task(self._collect_stderr(self._proc.stderr))
        try:
            line = await self._read_line(timeout, "the ready line")
        except ShimProtocolError as exc:
            await self.kill()
            raise ShimStartError(str(exc)) from exc
        problems = validate_line(line)
        if problems or not isinstance(line, dict) or line.get("event") != "ready":
            await self.kill()
            raise ShimStartError(
                f"the first line is not a valid ready event: {'; '.join(problems)}"
            )
        self.ready_after = time.monotonic() - self.started_at
        self.info = ShimInfo(
            library=line["library"], version=line["version"], protocol=line["protocol"]
        )
        return self.info

    async def _collect_stderr(self, stream: asyncio.StreamReader) -> None:
        while chunk := await stream.read(65_536):
            self._stderr += chunk
            excess = len(self._stderr) - STDERR_KEEP
            if excess > 0:  # keep the end: the last words before a crash matter most
                del self._stderr[:excess]
                self._stderr_dropped += excess

    @property
    def stderr_text(self) -> str:
        """What the shim wrote on standard error (its last STDERR_KEEP bytes)."""
        text = self._stderr.decode("utf-8", errors="backslashreplace")
        if self._stderr_dropped:
            text = f"[… {self._stderr_dropped} earlier bytes dropped]\n{text}"
        return text

    @property
    def returncode(self) -> int | None:
        """The exit code, once the shim has exited."""
        return None if self._proc is None else self._proc.returncode

    @property
    def running(self) -> bool:
        """Whether the shim process is alive."""
        return self._proc is not None and self._proc.returncode is None

    async def close(self, timeout: float) -> int | None:
        """Close stdin and wait for the shim to exit (killed after `timeout`); return its code."""
        proc = self._proc
        if proc is None:
            return None
        if proc.stdin is not None and not proc.stdin.is_closing():
            proc.stdin.close()  # end of input means close (PROTOCOL.md)
        try:
            await asyncio.wait_for(proc.wait(), timeout)
        except TimeoutError:
            await self.kill()
            return None
        finally:
            await self._finish_stderr()
        return proc.returncode

    async def kill(self) -> None:
        """Kill the shim (if it still runs) and reap it."""
        proc = self._proc
        if proc is None:
            return
        if proc.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                proc.kill()
        with contextlib.suppress(Exception):
            await asyncio.wait_for(proc.wait(), 5.0)
        await self._finish_stderr()

    async def _finish_stderr(self) -> None:
        task = self._stderr_task
        if task is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(asyncio.shield(task), 2.0)
            task.cancel()

    # -- commands --------------------------------------------------------------------------------

    async def command(self, cmd: str, fields: Mapping[str, Any], timeout: float) -> dict[str, Any]:
        """Send one command and return its checked answer; ShimProtocolError otherwise."""
        if cmd not in COMMANDS and cmd not in STREAM_COMMANDS:
            raise ValueError(f"not a shim command: {cmd!r}")
        async with self._lock:  # the kit never pipelines commands (PROTOCOL.md)
            self._seq += 1
            seq = self._seq
            await self._send({"seq": seq, "cmd": cmd, **fields})
            line = await self._read_line(timeout, f"the answer to {cmd} (seq {seq})")
        said = line.get("seq") if isinstance(line, dict) else None
        if isinstance(said, int) and said != seq:  # an answer to another command
            raise ShimProtocolError(f"the answer to {cmd} carries seq {said}, not {seq}")
        problems = validate_line(line, cmd)
        if problems:
            raise ShimProtocolError(f"invalid answer to {cmd}: {'; '.join(problems[:5])}")
        answer: dict[str, Any] = line
        return answer

    async def _send(self, command: dict[str, Any]) -> None:
        proc = self._proc
        if proc is None or proc.stdin is None:
            raise ShimProtocolError("the shim is not running")
        text = json.dumps(command)
        if self._on_line is not None:
            self._on_line("out", text)
        try:
            proc.stdin.write(text.encode("utf-8") + b"\n")
            await proc.stdin.drain()
        except (ConnectionError, OSError) as exc:
            raise ShimProtocolError(f"the shim does not read its input: {exc}") from exc

    async def _read_line(self, timeout: float, what: str) -> Any:
        proc = self._proc
        assert proc is not None and proc.stdout is not None
        try:
            raw = await asyncio.wait_for(proc.stdout.readline(), timeout)
        except TimeoutError:
            raise ShimProtocolError(f"no {what} within {timeout:.1f} s") from None
        except (ValueError, asyncio.LimitOverrunError) as exc:
            raise ShimProtocolError(f"{what}: a line longer than {MAX_LINE} bytes") from exc
        if not raw:
            code = await self._exit_code()
            raise ShimProtocolError(f"the shim closed its output (exit code {code}) before {what}")
        text = raw.decode("utf-8", errors="backslashreplace").rstrip("\r\n")
        if self._on_line is not None:
            self._on_line("in", text)
        try:
            return json.loads(text)
        except ValueError as exc:
            raise ShimProtocolError(f"{what} is not JSON: {exc}") from exc

    async def _exit_code(self) -> int | None:
        proc = self._proc
        if proc is None:
            return None
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(proc.wait(), 2.0)
        return proc.returncode
