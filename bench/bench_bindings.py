"""Throughput of one C++ and one Java client, and the C++ decode cost of a wakeup, vs Python.

Cases (the baseline, measured in the same run, in brackets):
- noreply posts/s from one client to the reference server: N posts of about 256 bytes of XML
  with `noreply="yes"`, then one PING whose reply proves the server has read them all; C++
  (`bindings/cpp/build/openair-bench post`) and Java (`org.openair.shim.BenchMain post` in
  `bindings/java/target/openair-shim.jar`) [the Python `openair.client.Module` doing the same,
  `post(..., noreply=True)` in a loop]. Each client binds with BIND_NOLISTEN and runs in its own
  process on the CPUs the server (pinned to CPU 0) does not use, against a fresh server, so the
  whiteboard's history is the same size for every language. The ratio is client / Python.
- the decode cost of one wakeup (a 256-byte post's `AIR.Instruct.Wakeup`, built with
  `openair.protocol.wakeup.build_wakeup`): C++ `decode_message`, and `decode_message` +
  `parse_wakeup` [Python's `openair.protocol.codec.decode_message`, and with `parse_wakeup`]. The
  ratio is C++ / Python µs (below 1: C++ is cheaper).
Nothing is built here: a missing binary or jar is reported as a 0 figure with a note.
`python -m bench.bench_bindings post HOST PORT N SIZE` is the Python client's side.
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

from bench import Result, per_call
from bench.bench_server import _cpu_seconds, _pin_load, _process, _server_argv
from openair.client import Module
from openair.protocol.codec import decode_message, encode_message
from openair.protocol.content import Phase, Trigger
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.wakeup import build_wakeup, parse_wakeup

BENCH = "bindings"
_COUNT = int(os.environ.get("BENCH_BINDINGS_COUNT", "20000"))
_SIZE = 256
_DECODES = 2000  # per round of the C++ decode loop (best of 5 rounds)
_TYPE = "Bench.Flow.Data"
_WHITEBOARD = "WB1"
_ROOT = Path(__file__).resolve().parent.parent
_CPP_BENCH = _ROOT / "bindings/cpp/build/openair-bench"
_JAVA_JAR = _ROOT / "bindings/java/target/openair-shim.jar"
_TIMEOUT = 300.0


@dataclass(frozen=True, slots=True, kw_only=True)
class Posts:
    """What one client's run of noreply posts measured."""

    posts: int
    seconds: float  # first post to the PING reply
    send_seconds: float  # first post to the last one handed to the client library
    server_cpu_s: float

    @property
    def per_s(self) -> float:
        return self.posts / self.seconds

    @property
    def note(self) -> str:
        send_rate = self.posts / max(self.send_seconds, 1e-9)
        cpu = self.server_cpu_s * 1e6 / self.posts
        return f"sent at {send_rate:,.0f}/s; {cpu:.1f} µs server CPU/post"


# ----------------------------------------------------------------------- the Python client


def _padding(sender: str, size: int) -> str:
    """Return content that makes a post's XML about `size` bytes (its envelope encoded once)."""
    probe = Message(type=_TYPE, sender=sender, to=_WHITEBOARD, noreply=True, posted=AirTime(sec=0))
    return "x" * max(0, size - len(encode_message(probe)))


async def _python_posts(host: str, port: int, count: int, size: int) -> dict[str, float]:
    """Post `count` noreply messages with `Module`, then PING; return the client's JSON figures."""
    module = Module("BenchPy", host, port, listen=False, announce=False, reconnect=False)
    async with module:
        caps = module.capabilities
        if caps is None or "noreply" not in caps.extensions or "noreply" not in module.extensions:
            raise RuntimeError("the server does not advertise noreply")
        content = _padding(module.name, size)
        start = time.perf_counter()
        for _ in range(count):
            await module.post(_WHITEBOARD, _TYPE, content, noreply=True)
        sent = time.perf_counter()
        await module.ping()  # answered in order (OA-SESS-2): every post was read
        done = time.perf_counter()
    return {"posts": count, "seconds": done - start, "send_seconds": sent - start}


# ----------------------------------------------------------------------- running the clients


def _client_argv(language: str, port: int) -> list[str] | None:
    """Return the command that runs one client's post mode, or None when it is not built."""
    args = ["post", "127.0.0.1", str(port), str(_COUNT), str(_SIZE)]
    if language == "Python":
        return [sys.executable, "-m", "bench.bench_bindings", *args]
    if language == "C++":
        return [str(_CPP_BENCH), *args] if _CPP_BENCH.is_file() else None
    java = shutil.which("java")
    if java is None or not _JAVA_JAR.is_file():
        return None
    return [java, "-cp", str(_JAVA_JAR), "org.openair.shim.BenchMain", *args]


def _run_client(argv: list[str]) -> dict[str, float]:
    """Run a client off the server's CPU and return the JSON it printed."""
    done = subprocess.run(
        argv,
        cwd=_ROOT,
        capture_output=True,
        text=True,
        timeout=_TIMEOUT,
        preexec_fn=_pin_load,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"{argv[0]} failed ({done.returncode}): {done.stderr.strip()[-500:]}")
    figures: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


def _posts(language: str) -> Posts | None:
    """Measure one language's client against a fresh server; None when it is not built."""
    with _process(_server_argv()) as (pid, port):
        argv = _client_argv(language, port)
        if argv is None:
            return None
        cpu0 = _cpu_seconds(pid)
        figures = _run_client(argv)
        cpu = _cpu_seconds(pid) - cpu0
    return Posts(
        posts=int(figures["posts"]),
        seconds=figures["seconds"],
        send_seconds=figures.get("send_seconds", figures["seconds"]),
        server_cpu_s=cpu,
    )


def _not_built(case: str, unit: str, make: str) -> Result:
    return Result(bench=BENCH, case=case, value=0.0, unit=unit, note=f"not built: run {make}")


def _post_results() -> list[Result]:
    base = _posts("Python")
    assert base is not None
    results = [
        Result(
            bench=BENCH,
            case="Python client noreply posts",
            value=base.per_s,
            unit="posts/s",
            ratio=1.0,
            note=f"baseline; {base.note}",
        )
    ]
    for language, make in (("C++", "make cpp"), ("Java", "make java")):
        case = f"{language} client noreply posts"
        flow = _posts(language)
        if flow is None:
            results.append(_not_built(case, "posts/s", make))
            continue
        ratio = flow.per_s / base.per_s
        results.append(Result(bench=BENCH, case=case, value=flow.per_s, unit="posts/s",
                              ratio=ratio, note=flow.note))  # fmt: skip
    return results


# ----------------------------------------------------------------------------- decoding


def wakeup_xml(size: int = _SIZE) -> bytes:
    """Return the XML of the wakeup a server sends for one post of about `size` bytes."""
    content = _padding("BenchPoster", size)
    stored = Message(
        type=_TYPE,
        sender="BenchPoster",
        to=_WHITEBOARD,
        stored=_WHITEBOARD,
        noreply=True,
        content=content,
        posted=AirTime.from_ms(1_790_000_000_123),
        received=AirTime.from_ms(1_790_000_000_124),
        wbid=1,
    )
    phase = Phase(name="Default", triggers=(Trigger(pattern="Bench.Flow.*"),))
    wakeup = build_wakeup(
        stored=stored,
        whiteboard=_WHITEBOARD,
        module="BenchSub",
        phase=phase,
        lasttrigger="Bench.Flow.*",
    )
    # stamped with postedTime as its sender does (OA-TIME-2)
    return encode_message(replace(wakeup, posted=AirTime.from_ms(1_790_000_000_125)))


def _python_wakeup(xml: bytes) -> object:
    return parse_wakeup(decode_message(xml))


def _decode_results() -> list[Result]:
    xml = wakeup_xml()
    py_decode = per_call(decode_message, [xml]) * 1e6
    py_wakeup = per_call(_python_wakeup, [xml]) * 1e6
    note = f"{len(xml)}-byte wakeup"
    results = [
        Result(bench=BENCH, case="Python decode_message (wakeup)", value=py_decode,
               unit="µs", ratio=1.0, note=f"baseline; {note}"),
        Result(bench=BENCH, case="Python decode + parse_wakeup", value=py_wakeup,
               unit="µs", ratio=1.0, note="baseline"),
    ]  # fmt: skip
    if not _CPP_BENCH.is_file():
        return [*results, _not_built("C++ decode_message (wakeup)", "µs", "make cpp")]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "wakeup.xml"
        path.write_bytes(xml)
        figures = _run_client([str(_CPP_BENCH), "decode", str(path), str(_DECODES)])
    cpp_decode, cpp_wakeup = figures["per_decode_us"], figures["per_wakeup_us"]
    return [
        *results,
        Result(bench=BENCH, case="C++ decode_message (wakeup)", value=cpp_decode, unit="µs",
               ratio=cpp_decode / py_decode, note="ratio < 1: cheaper than Python"),
        Result(bench=BENCH, case="C++ decode + parse_wakeup", value=cpp_wakeup, unit="µs",
               ratio=cpp_wakeup / py_wakeup),
    ]  # fmt: skip


def run() -> list[Result]:
    """Measure every client's noreply posts and the C++ decode cost against Python."""
    return _post_results() + _decode_results()


def _main(argv: list[str]) -> int:
    """Run the Python client's post mode: `post HOST PORT N SIZE`; print its JSON figures."""
    if len(argv) != 5 or argv[0] != "post":
        print("usage: python -m bench.bench_bindings post HOST PORT N SIZE", file=sys.stderr)
        return 2
    host, port, count, size = argv[1], int(argv[2]), int(argv[3]), int(argv[4])
    print(json.dumps(asyncio.run(_python_posts(host, port, count, size))))
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
