"""Raw OpenAIR peers for the attacks, and the canary that times PING round trips."""

from __future__ import annotations

import asyncio
import contextlib
import os
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message

__all__ = ["Canary", "Raw", "frame_of", "p99"]

BOUND_S = 60.0


def frame_of(msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> bytes:
    """Return the frame bytes of `msg`."""
    return encode_frame(to_frame(msg, tag))


#: The send buffer of every attacking socket. The kernel grows a loopback socket's buffer to
#: megabytes, and one `send` then copies and delivers them in one call that, on this machine's
#: kernel (no preemption inside system calls), holds a processor for milliseconds: the server's
#: loop waited for it (`perf sched`, 2026-11-29). A remote attacker's kernel does that work on
#: its own host, and a network card's receive path takes a bounded batch at a time. Measured
#: on slowloris (three runs each): canary p99 2.8-3.9 ms with the grown buffer, 1.1-1.4 ms
#: with this one; the attacks are as large either way.
ATTACKER_SNDBUF = 256 * 1024


class Raw:
    """A raw connection: write frames or bytes, read whole messages back."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer
        self.frames = FrameReader()
        self.eof = False

    @classmethod
    async def open(cls, port: int) -> Raw:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        sock = writer.get_extra_info("socket")
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, ATTACKER_SNDBUF)
        return cls(reader, writer)

    def send(self, msg: Message, tag: FrameTag = FrameTag.MESSAGE) -> None:
        self.writer.write(frame_of(msg, tag))

    async def recv(self) -> Message | None:
        """Return the next message, or None at end of stream."""
        async with asyncio.timeout(BOUND_S):
            while True:
                frame = self.frames.next_frame()
                if frame is not None:
                    return from_frame(frame)
                if self.eof:
                    return None
                try:
                    data = await self.reader.read(1 << 16)
                except ConnectionError:
                    data = b""
                self.eof = not data
                if data:
                    self.frames.feed(data)

    async def request(self, msg: Message) -> Message | None:
        self.send(msg)
        return await self.recv()

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.writer.close()


def p99(values: list[float]) -> float:
    """Return the 99th percentile of `values` (0.0 when empty)."""
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(len(ordered) * 0.99))]


@dataclass(slots=True)
class Canary:
    """A client in a process of its own that PINGs every `period_s` and records round trips.

    Its own process (not a thread of the attacking process): the attacks encode and decode
    frames of megabytes, and a thread sharing their interpreter lock would time the attacker's
    work as the server's. Each sample is `(began, ms)`, `began` on the monotonic clock that
    every process of the machine shares, so `between` picks the PINGs sent in a time window
    however late their lines arrive. A PING that gets no answer within the socket timeout
    counts as one of `timeouts`.

    The canary runs ahead of the server in the processor's queue when the user may arrange it
    (`_raise_priority`): it stands for another host's client, whose own scheduling is not the
    server's doing. On this machine the kernel wakes it on the processor of the server that just
    wrote its answer. Measured (2026-11-29, monitor-half-requests): the server wrote the answers
    of the slowest PINGs 0.2-1.3 ms after they were sent, the canary read them 4-5 ms after; at
    nice -10 its p99 fell from 5-6 ms to 2 ms. Nice -10 was not enough under the heavier
    attacks: `perf sched timehist` over history-bytes (2026-11-29, eighth session) showed the
    canary waiting for a processor more than 0.5 ms 67 times in 2 s (max 3.8 ms; the kernel's
    EEVDF scheduler lets the running task finish its slice), so it now asks for the real-time
    FIFO class, which takes the processor at once. `policy` is what it got (None until it said).
    """

    port: int
    period_s: float = 0.005
    samples: list[tuple[float, float]] = field(default_factory=list)
    timeouts: int = 0
    policy: str | None = None
    _proc: subprocess.Popen[str] | None = None
    _thread: threading.Thread | None = None

    def start(self) -> None:
        cmd = [sys.executable, "-m", "bench.stress.wire", str(self.port), str(self.period_s)]
        self._proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
        self._thread = threading.Thread(target=self._collect, daemon=True)
        self._thread.start()

    def before(self, began: float, ended: float) -> list[float]:
        """Return the round trips (ms) of the PINGs sent and answered from `began` to `ended`."""
        kept = [ms for at, ms in list(self.samples) if at >= began and at + ms / 1000 < ended]
        return self._with_omitted(kept)

    def during(self, began: float, ended: float) -> list[float]:
        """Return the round trips (ms) of the PINGs in flight at any time from `began` to `ended`.

        A PING sent before `began` that the attack held up counts, and so does one sent before
        `ended` and answered after it: `settle` waits for those answers first.
        """
        kept = [ms for at, ms in list(self.samples) if at < ended and at + ms / 1000 >= began]
        return self._with_omitted(kept)

    def _with_omitted(self, round_trips: list[float]) -> list[float]:
        """Add the PINGs a stall kept the canary from sending (coordinated omission).

        The canary waits for each answer before it sends the next PING, so a 2 s stall yields
        one sample, not the hundred a client sending every `period_s` would have seen delayed:
        a few long stalls in a long attack would vanish below the 99th percentile. For a round
        trip of r ms, the PINGs due every period during it count as r - p, r - 2p, ... ms.
        """
        period = self.period_s * 1000
        out: list[float] = []
        for ms in round_trips:
            out.append(ms)
            while ms > 2 * period:
                ms -= period
                out.append(ms)
        return out

    def settle(self, ended: float, limit_s: float = 60.0) -> None:
        """Wait until a PING sent after `ended` was answered (at most `limit_s`)."""
        give_up = time.monotonic() + limit_s
        while time.monotonic() < give_up:
            if self.samples and self.samples[-1][0] >= ended:
                return
            time.sleep(0.02)

    def stop(self) -> None:
        if self._proc is not None:
            self._proc.terminate()
            self._proc.wait(10.0)
        if self._thread is not None:
            self._thread.join(10.0)

    def _collect(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        for line in self._proc.stdout:
            if line.startswith("timeout"):
                self.timeouts += 1
            elif line.startswith("policy "):
                self.policy = line.split(maxsplit=1)[1].strip()
            elif line.strip():
                at, ms = line.split()
                self.samples.append((float(at), float(ms)))


#: The canary's niceness when it may not use the real-time class: before the server's (0).
CANARY_NICE = -10
#: Its real-time priority, the lowest: above every task of the ordinary class, the server's too.
CANARY_FIFO = 1


def _raise_priority() -> str:
    """Take the FIFO real-time class, else `CANARY_NICE`, as far as allowed; say which.

    The canary sleeps between PINGs and blocks on each answer, so it holds a processor for
    tens of microseconds at a time; the kernel's real-time throttling bounds it besides.
    """
    with contextlib.suppress(OSError, AttributeError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(CANARY_FIFO))
        return f"fifo {CANARY_FIFO}"
    with contextlib.suppress(OSError):
        os.setpriority(os.PRIO_PROCESS, 0, CANARY_NICE)
    return f"nice {os.getpriority(os.PRIO_PROCESS, 0)}"


def ping_forever(port: int, period_s: float) -> None:
    """The canary process: PING the server, print `began ms` per answer, until killed."""
    print(f"policy {_raise_priority()}", flush=True)
    # From another loopback address than the attacks: the canary is another host's client,
    # and the server shares its time between peer addresses (--fair-slice-ms).
    with socket.create_connection(
        ("127.0.0.1", port), timeout=10.0, source_address=("127.0.0.9", 0)
    ) as sock:
        ping = frame_of(Message(type="PING", to="CNS", sender="Canary"))
        reader = FrameReader()
        while True:
            began = time.monotonic()
            sock.sendall(ping)
            try:
                while reader.next_frame() is None:
                    data = sock.recv(1 << 16)
                    if not data:
                        return
                    reader.feed(data)
            except TimeoutError:
                print("timeout", flush=True)
                continue
            print(f"{began:.6f} {(time.monotonic() - began) * 1000:.3f}", flush=True)
            time.sleep(period_s)


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt, BrokenPipeError):
        ping_forever(int(sys.argv[1]), float(sys.argv[2]))
