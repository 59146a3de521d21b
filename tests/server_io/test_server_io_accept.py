"""Out of file descriptors: the accept loop backs off and logs one line, not a traceback each.

The server runs in a subprocess whose RLIMIT_NOFILE is low; the test opens more connections
than it may accept and reads the server's log until the accept failure is reported (issue #19,
item 5).
"""

from __future__ import annotations

import contextlib
import resource
import selectors
import signal
import socket
import subprocess
import sys
import time

_NOFILE = 48  # descriptors the server may hold: a few dozen connections
_BOUND_S = 20.0


def _limit_files() -> None:
    resource.setrlimit(resource.RLIMIT_NOFILE, (_NOFILE, _NOFILE))


def _read_until(proc: subprocess.Popen[str], stream: str, needle: str) -> list[str]:
    """Read lines of the server's stdout or stderr until one contains `needle`."""
    pipe = proc.stdout if stream == "stdout" else proc.stderr
    assert pipe is not None
    lines: list[str] = []
    selector = selectors.DefaultSelector()
    selector.register(pipe, selectors.EVENT_READ)
    end = time.monotonic() + _BOUND_S
    while time.monotonic() < end:
        if not selector.select(end - time.monotonic()):
            break
        line = pipe.readline()
        if not line:
            break
        lines.append(line)
        if needle in line:
            return lines
    raise AssertionError(f"{needle!r} never appeared in {stream}: {lines[-20:]}")


def test_accept_failures_for_lack_of_descriptors_are_one_log_line() -> None:
    cmd = [sys.executable, "-m", "openair.cli", "serve", "--port", "0", "--no-monitor"]
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        bufsize=1,
        preexec_fn=_limit_files,
    )
    socks: list[socket.socket] = []
    try:
        ready = _read_until(proc, "stdout", "listening on")[-1]
        port = int(ready.split()[2].rsplit(":", 1)[1])
        for _ in range(_NOFILE + 20):  # more than it can accept: accept() fails with EMFILE
            socks.append(socket.create_connection(("127.0.0.1", port), timeout=_BOUND_S))
        log = _read_until(proc, "stderr", "event=accept_failed")
        assert "errno=EMFILE" in log[-1]
        for sock in socks:
            sock.close()
        socks.clear()
        proc.send_signal(signal.SIGTERM)
        _, rest = proc.communicate(timeout=_BOUND_S)
        text = "".join(log) + rest
        assert "Traceback" not in text and "out of system resource" not in text
        assert text.count("event=accept_failed") <= 2  # one line per interval, not per accept
    finally:
        for sock in socks:
            sock.close()
        if proc.poll() is None:
            proc.kill()
        with contextlib.suppress(Exception):
            proc.communicate(timeout=_BOUND_S)
