"""Nothing acknowledged then lost under a real memory limit (issue #19, OA-LIM-14).

The server runs as its own process under an address-space limit (prlimit) a few hundred MiB
above what it uses idle, with `max-held-bytes` below that limit and a history that never evicts.
Megabyte posts go in until the server refuses one: it must refuse with LIMIT_EXCEEDED, stay up,
and every post it acknowledged must be stored — not run out of memory between storing a post
and acknowledging it, as it did before the held-bytes budget.
"""

from __future__ import annotations

import contextlib
import resource
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.framing import FrameReader, encode_frame
from openair.protocol.message import Message
from openair.protocol.objects import parse_dictionary

MIB = 1 << 20
_HEADROOM = 300 * MIB  # address space allowed above the idle server's
_HELD = 48 * MIB  # max-held-bytes: far below the headroom


def _vm_size(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmSize")


class _Conn:
    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=30)
        self.reader = FrameReader()

    def request(self, msg: Message) -> Message | None:
        self.sock.sendall(encode_frame(to_frame(msg)))
        while (frame := self.reader.next_frame()) is None:
            data = self.sock.recv(1 << 16)
            if not data:
                return None
            self.reader.feed(data)
        return from_frame(frame)


@pytest.mark.skipif(not hasattr(resource, "prlimit"), reason="prlimit(2) is Linux only")
def test_under_a_memory_limit_a_post_is_refused_before_it_is_acknowledged() -> None:
    code = "from openair.server.cli_serve import serve; serve()"
    argv = [sys.executable, "-c", code, "--port", "0", "--log-level", "error", "--no-monitor"]
    argv += [f"--max-held-bytes={_HELD}", f"--max-history-bytes={1 << 40}"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        port = int(line.split(":", 1)[1].split()[0])
        limit = _vm_size(proc.pid) + _HEADROOM
        resource.prlimit(proc.pid, resource.RLIMIT_AS, (limit, limit))
        conn = _Conn(port)
        body = "x" * MIB
        acked, refusal = 0, None
        for i in range(320):  # 320 MiB: past the limit had nothing refused them
            reply = conn.request(Message(type=f"Test.Mem.{i}", to="WB1", sender="P", content=body))
            assert reply is not None, f"the server closed after {acked} acknowledged posts"
            if reply.type != "RECEIVE_ACCEPT":
                refusal = reply
                break
            acked += 1
        assert refusal is not None and "LIMIT_EXCEEDED" in refusal.content, refusal
        assert 0 < acked <= _HELD // MIB
        status = conn.request(Message(type="STATUS", to="CNS", sender="P"))
        assert proc.poll() is None and status is not None  # alive and answering
        entries = dict(parse_dictionary(status.content).entries)
        assert int(entries["whiteboards.WB1.stored"]) == acked  # every acknowledged one kept
        conn.sock.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=20)
        if proc.poll() is None:
            proc.kill()
