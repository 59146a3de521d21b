"""Helpers for the tests of the kit as users run it: `openair` as a child process.

`ServeProcess` runs `openair serve` on 127.0.0.1 and a free port (or the port its arguments
name), reads the `listening on HOST:PORT` line, and stops it with a signal, returning the exit
code. Waits are bounded by deadlines given to the operating system (no sleeps).
"""

from __future__ import annotations

import os
import re
import selectors
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LISTENING = re.compile(r"listening on [^ ]*:(\d+)")
#: How long a test waits for a server to start or to stop (a bound, not a measurement).
START_S = 30.0
STOP_S = 30.0


def openair_command(python: Path | None = None) -> list[str]:
    """The `openair` console script beside `python` (default: this interpreter)."""
    exe = Path(python or sys.executable).with_name("openair")
    return [str(exe)] if exe.exists() else [str(python or sys.executable), "-m", "openair.cli"]


def free_port() -> int:
    """A port that was free on 127.0.0.1 a moment ago."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class ServeProcess:
    """`openair serve ARGS` as a child process; `port` is where it listens."""

    def __init__(self, *args: str, python: Path | None = None, port0: bool = True) -> None:
        extra = ["--port", "0"] if port0 and "--port" not in args else []
        cmd = [*openair_command(python), "serve", "--host", "127.0.0.1", *extra, *args]
        # stderr goes to a file: a pipe nobody reads would fill up and block the server's log.
        self._err = tempfile.TemporaryFile()  # noqa: SIM115  (closed by kill())
        self.proc = subprocess.Popen(
            cmd,
            stdout=subprocess.PIPE,
            stderr=self._err,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.port = self._wait_listening()

    def _wait_listening(self) -> int:
        """Read stdout until the `listening on` line; fail with stderr if the server exits."""
        assert self.proc.stdout is not None
        deadline = time.monotonic() + START_S
        with selectors.DefaultSelector() as sel:
            sel.register(self.proc.stdout, selectors.EVENT_READ)
            while time.monotonic() < deadline:
                if not sel.select(timeout=deadline - time.monotonic()):
                    break
                line = self.proc.stdout.readline().decode("utf-8", "replace")
                if not line:
                    break
                found = LISTENING.search(line)
                if found:
                    return int(found.group(1))
        err = self.stderr()
        self.kill()
        raise AssertionError(f"openair serve did not start: {err}")

    def stop(self, sig: int = signal.SIGTERM, timeout: float = STOP_S) -> int | None:
        """Send `sig`; return the exit code, or None when it did not exit within `timeout`."""
        self.proc.send_signal(sig)
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
        return self.proc.returncode

    def stderr(self) -> str:
        """What the server wrote on stderr so far."""
        self._err.seek(0)
        return self._err.read().decode("utf-8", "replace")

    def kill(self) -> None:
        """End the process for good (test clean-up)."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(STOP_S)
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._err.close()
