"""Start, measure and stop each broker: pinned to CPU 0, on 127.0.0.1, on a free port.

Every broker runs with a minimal configuration: no persistence, no authentication, defaults for
everything else (so their own limits on slow consumers apply). The process's CPU time comes from
/proc/PID/stat (all threads), its resident set from /proc/PID/status, and its peak (VmHWM) is
reset before each workload through /proc/PID/clear_refs when the kernel allows it.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from bench.loadgen import pin

PROTOCOL = {
    "openair": "openair",
    "relay": "relay",
    "mosquitto": "mqtt",
    "amqtt": "mqtt",
    "nats": "nats",
    "redis": "redis",
}
_VENV_BIN = Path(sys.executable).parent
_ROOT = Path(__file__).resolve().parents[2]
_STREAMS_CONFIG = """<?xml version="1.0" encoding="UTF-8"?>
<psySpec name="BenchPeers" version="1.2">
  <whiteboard name="AIRCentral"/>
  <whiteboard name="WB1"><streams><stream name="Video" maxsize="64"/></streams></whiteboard>
</psySpec>
"""


@dataclass(frozen=True, slots=True, kw_only=True)
class Broker:
    """One running broker."""

    name: str
    pid: int
    port: int

    @property
    def protocol(self) -> str:
        return PROTOCOL[self.name]


def free_port() -> int:
    """Return a TCP port that was free on 127.0.0.1 a moment ago."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _argv(name: str, port: int, tmp: Path) -> list[str]:
    """Return the command line that runs broker `name` on `port` (config files go to `tmp`)."""
    if name == "mosquitto":
        conf = tmp / "mosquitto.conf"
        conf.write_text(
            f"listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"
            "log_dest stderr\nlog_type error\n"
        )
        return [_which("mosquitto"), "-c", str(conf)]
    if name == "nats":
        return [_which("nats-server"), "-a", "127.0.0.1", "-p", str(port)]
    if name == "redis":
        return [
            _which("redis-server"),
            "--port",
            str(port),
            "--bind",
            "127.0.0.1",
            "--save",
            "",
            "--appendonly",
            "no",
            "--protected-mode",
            "no",
            "--loglevel",
            "warning",
        ]
    if name == "amqtt":
        conf = tmp / "amqtt.yaml"
        conf.write_text(
            f"listeners:\n  default:\n    type: tcp\n    bind: 127.0.0.1:{port}\nplugins:\n"
            "  amqtt.plugins.authentication.AnonymousAuthPlugin:\n    allow_anonymous: true\n"
        )
        return [str(_VENV_BIN / "amqtt"), "-c", str(conf)]
    if name == "openair":
        spec = tmp / "peers.psySpec.xml"
        spec.write_text(_STREAMS_CONFIG)
        code = "from openair.cli import main; main()"
        return [
            sys.executable,
            "-c",
            code,
            "serve",
            "--port",
            str(port),
            "--log-level",
            "warning",
            "--config",
            str(spec),
        ]
    if name == "relay":
        return [sys.executable, "-m", "bench.relay", "--port", str(port)]
    raise ValueError(f"unknown broker {name!r}")


def _which(program: str) -> str:
    for folder in (None, "/usr/sbin", "/usr/local/sbin", "/sbin"):
        found = shutil.which(program, path=folder)
        if found:
            return found
    raise FileNotFoundError(f"{program} is not installed (run `make bench-peers`)")


def missing_reason(name: str) -> str:
    """Return why broker `name` cannot run here, or "" when it can."""
    try:
        _argv(name, 1, Path(tempfile.gettempdir()))
    except FileNotFoundError as exc:
        return str(exc)
    if name == "amqtt" and not (_VENV_BIN / "amqtt").exists():
        return "amqtt is not installed in the venv (run `make bench-peers`)"
    return ""


def _wait_port(port: int, proc: subprocess.Popen[bytes], timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"broker exited with status {proc.returncode}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
            return
        except OSError:
            time.sleep(0.05)
    raise RuntimeError(f"broker did not listen on {port} within {timeout} s")


@contextmanager
def running(name: str) -> Iterator[Broker]:
    """Start broker `name` pinned to CPU 0; stop it (terminate, then kill) on exit."""
    with tempfile.TemporaryDirectory(prefix=f"peers-{name}-") as tmp:
        port = free_port()
        proc = subprocess.Popen(
            _argv(name, port, Path(tmp)),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=lambda: pin(0),
            cwd=tmp,
            env={**os.environ, "PYTHONPATH": str(_ROOT)},
        )
        try:
            _wait_port(port, proc)
            yield Broker(name=name, pid=proc.pid, port=port)
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=10)


def cpu_seconds(pid: int) -> float:
    """Return the user + system CPU seconds of process `pid` (every thread)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def wait_seconds(pid: int) -> float:
    """Return how long the threads of `pid` waited, runnable, for a CPU (schedstat)."""
    total = 0
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/schedstat") as f:
                total += int(f.read().split()[1])
    except (OSError, IndexError, ValueError):
        pass
    return total / 1e9


def memory_kib(pid: int, key: str) -> int:
    """Return a /proc/PID/status figure in KiB (VmRSS, VmHWM), or 0 when unavailable."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def reset_peak(pid: int) -> bool:
    """Reset VmHWM to the current RSS (Linux clear_refs "5"); return whether it worked."""
    try:
        with open(f"/proc/{pid}/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def version(name: str) -> str:
    """Return the version string of broker `name` (or why it is unknown)."""
    try:
        if name == "openair":
            return "openair-kit " + metadata.version("openair-kit")
        if name == "relay":
            return "bench.relay"
        if name == "amqtt":
            return "amqtt " + metadata.version("amqtt")
        argv = {
            "mosquitto": [_which("mosquitto"), "-h"],
            "nats": [_which("nats-server"), "--version"],
            "redis": [_which("redis-server"), "--version"],
        }[name]
        out = subprocess.run(argv, capture_output=True, text=True, timeout=10)
        text = (out.stdout or out.stderr).strip().splitlines()
        return text[0].strip() if text else "unknown"
    except (OSError, KeyError, metadata.PackageNotFoundError, subprocess.SubprocessError) as exc:
        return f"unknown ({exc})"
