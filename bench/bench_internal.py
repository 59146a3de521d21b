"""Internal modules (OA-CONF-8): the same echo module inside the server and over TCP.

The module is woken by `Bench.Ping` on WB1 and posts `Bench.Pong` with the ping's content; a
listener module (TCP, in this process) is woken by the pong. Both runs use the same module logic
(`pong_content`) and differ in transport: `<module internal="bench.bench_internal:echo">` in the
psySpec (the stored ping handed over by `InternalModule.trigger`, the pong routed in memory), or
a module process that binds over TCP (callback connection, `pipelining`), reads the wakeup frame
(`parse_wakeup`) and writes its pong as a frame.

Cases: round trip ping → pong (sequential, p50), and a burst of pings (pong/s). The ratio column
is the gain of the internal module over the TCP one, measured in the same run; the note gives
the load average, because other processes on the machine change both figures.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import statistics
import time
from multiprocessing.synchronize import Event

from bench import Result
from bench.loadgen import SubscriberSpec, _ack, _setup_module, connect, frame, message, read_frames
from bench.serving import spawn
from openair.protocol.codec import decode_message, encode_message
from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup
from openair.server.aio.internal import InternalModule

BENCH = "internal"
_ROUND_TRIPS = int(os.environ.get("BENCH_INTERNAL_ROUND_TRIPS", "2000"))
_BURST = int(os.environ.get("BENCH_INTERNAL_BURST", "20000"))
_WINDOW = 500  # pings ahead of the pongs received
_CTX = mp.get_context("fork")

_SPEC = """<psySpec name="BenchInternal" version="1.2">
  <whiteboard name="WB1"/>
  {module}
</psySpec>"""
_INTERNAL = (
    '<module name="Echo" internal="bench.bench_internal:echo">'
    '<trigger from="WB1" type="Bench.Ping"/></module>'
)


def pong_content(trigger: Message | None) -> str | None:
    """The module's logic: the content of the ping that woke it (None: not a wakeup)."""
    return trigger.content if trigger is not None else None


async def echo(module: InternalModule, msg: Message) -> None:
    """The echo module inside the server: the stored ping itself, the pong posted in memory."""
    content = pong_content(module.trigger(msg))
    if content is not None:
        module.post("WB1", "Bench.Pong", content)


def _tcp_echo(port: int, ready: Event) -> None:
    """The same echo module over TCP: acknowledge each wakeup, post the pong as a frame."""
    spec = SubscriberSpec(port=port, name="Echo", patterns=("Bench.Ping",), expected=0)
    primary, callback = _setup_module(spec)
    ready.set()
    buf = bytearray()
    try:
        while True:
            acks, pongs = [], []
            for xml in read_frames(callback, buf):
                msg = decode_message(xml, clamp_priority=True)
                acks.append(_ack(xml, "Echo"))
                wakeup = msg.type == "AIR.Instruct.Wakeup"
                content = pong_content(parse_wakeup(msg).trigger if wakeup else None)
                if content is not None:
                    pong = Message(
                        type="Bench.Pong", sender="Echo", to="WB1", content=content, noreply=True
                    )
                    pongs.append(frame(encode_message(pong)))
            callback.sendall(b"".join(acks))
            if pongs:
                primary.sendall(b"".join(pongs))
    except (ConnectionError, OSError):
        return


def _ping(i: int) -> bytes:
    return frame(
        message("Bench.Ping", sender="BenchPinger", to="WB1", content=f"P{i}", noreply=True)
    )


class _Listener:
    """The pinger and the listener module, in this process."""

    def __init__(self, port: int) -> None:
        spec = SubscriberSpec(port=port, name="Listener", patterns=("Bench.Pong",), expected=0)
        self.primary, self.callback = _setup_module(spec)
        self.pinger = connect(port)
        self._buf = bytearray()

    def pongs(self) -> int:
        """Read what arrived, acknowledge it, return how many pongs it held."""
        frames = read_frames(self.callback, self._buf)
        self.callback.sendall(b"".join(_ack(xml, "Listener") for xml in frames))
        return sum(1 for xml in frames if b"Bench.Pong" in xml)

    def round_trips(self, n: int) -> list[int]:
        lat = []
        for i in range(n):
            start = time.perf_counter_ns()
            self.pinger.sendall(_ping(i))
            while not self.pongs():
                pass
            lat.append(time.perf_counter_ns() - start)
        return lat

    def burst(self, n: int) -> float:
        sent = got = 0
        start = time.perf_counter()
        while got < n:
            if sent < n and sent - got < _WINDOW:
                batch = min(100, n - sent)
                self.pinger.sendall(b"".join(_ping(sent + k) for k in range(batch)))
                sent += batch
                continue
            got += self.pongs()
        return n / (time.perf_counter() - start)

    def close(self) -> None:
        for sock in (self.primary, self.callback, self.pinger):
            sock.close()


def _measure(internal: bool) -> tuple[float, float]:
    """Return (round-trip p50 in ms, burst pongs per second) for one kind of echo module."""
    with spawn(_SPEC.format(module=_INTERNAL if internal else "")) as (_, port):
        proc = None
        if not internal:
            ready = _CTX.Event()
            proc = _CTX.Process(target=_tcp_echo, args=(port, ready), daemon=True)
            proc.start()
            if not ready.wait(30):
                raise RuntimeError("the TCP echo module did not start")
        listener = _Listener(port)
        try:
            listener.round_trips(50)  # warm-up
            p50 = statistics.median(listener.round_trips(_ROUND_TRIPS)) / 1e6
            rate = listener.burst(_BURST)
        finally:
            listener.close()
            if proc is not None:
                proc.terminate()
                proc.join(10)
    return p50, rate


def run() -> list[Result]:
    """Measure the echo module over TCP, then inside the server."""
    tcp_p50, tcp_rate = _measure(internal=False)
    int_p50, int_rate = _measure(internal=True)
    load = "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    return [
        Result(bench=BENCH, case="round trip p50, TCP module", value=tcp_p50, unit="ms", ratio=1.0),
        Result(
            bench=BENCH,
            case="round trip p50, internal module",
            value=int_p50,
            unit="ms",
            ratio=tcp_p50 / int_p50,
            note=f"ratio = TCP / internal (gain); {load}",
        ),
        Result(bench=BENCH, case="burst, TCP module", value=tcp_rate, unit="pong/s", ratio=1.0),
        Result(
            bench=BENCH,
            case="burst, internal module",
            value=int_rate,
            unit="pong/s",
            ratio=int_rate / tcp_rate,
            note=f"ratio = internal / TCP (gain); {load}",
        ),
    ]
