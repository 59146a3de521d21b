"""Durable history over a crash and over a graceful stop (OA-WB-9, OA-WB-3, OA-ERR-5).

`openair serve --store sqlite:PATH` runs as a subprocess. Several connections post at once; the
test keeps the id of every post that got `RECEIVE_ACCEPT`. The server is killed (SIGKILL) in the
middle of the storm, or stopped with SIGTERM, and restarted on the same store: every acknowledged
post must be there, each poster's posts in the order it sent them (one request at a time, so
acknowledgement order is arrival order, OA-WB-12), and new posts continue the `wbid` sequence.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from wire_helpers import WAIT, RawConn, collection_messages, content_elements, now

from openair.protocol.message import Message
from openair.protocol.xmlsafe import local_name

BOARDS = ("WB1", "WB2")
POSTERS = 4
KILL_AFTER = 120  # acknowledged posts before the SIGKILL
LISTENING = re.compile(r"listening on [^ ]*:(\d+)")


class ServerProcess:
    """`openair serve` as a child process, on a free port, with its store."""

    def __init__(self, store: Path) -> None:
        exe = Path(sys.executable).with_name("openair")
        cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "openair.cli"]
        args = ["serve", "--host", "127.0.0.1", "--port", "0", "--store", f"sqlite:{store}"]
        self.proc = subprocess.Popen(
            [*cmd, *args], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
        )
        self.port = self._wait_listening()

    def _wait_listening(self) -> int:
        box: list[str] = []
        reader = threading.Thread(target=lambda: box.append(self._first_line()), daemon=True)
        reader.start()
        reader.join(WAIT)
        line = box[0] if box else ""
        match = LISTENING.search(line)
        if match is None:
            self.proc.kill()
            raise AssertionError(f"server did not report listening: {line!r}")
        return int(match.group(1))

    def _first_line(self) -> str:
        assert self.proc.stdout is not None
        return self.proc.stdout.readline()

    def signal(self, sig: int) -> int:
        """Send `sig` and wait (bounded) for the process to end; return its exit code."""
        self.proc.send_signal(sig)
        return self.proc.wait(WAIT)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(WAIT)


class Acks:
    """The (whiteboard, id) of every acknowledged post, in acknowledgement order, thread-safe."""

    def __init__(self) -> None:
        self.items: list[tuple[str, str]] = []
        self._cond = threading.Condition()

    def add(self, board: str, msg_id: str) -> None:
        with self._cond:
            self.items.append((board, msg_id))
            self._cond.notify_all()

    def wait_for(self, count: int) -> bool:
        """Wait (bounded) until `count` posts were acknowledged; True if they were."""
        with self._cond:
            return self._cond.wait_for(lambda: len(self.items) >= count, WAIT * 2)

    def snapshot(self) -> list[tuple[str, str]]:
        with self._cond:
            return list(self.items)


@pytest.fixture
def store(tmp_path: Path) -> Iterator[Path]:
    yield tmp_path / "history.sqlite"


def storm(port: int, poster: int, acked: Acks, stop: threading.Event) -> None:
    """Post one message at a time until told to stop or the server goes away."""
    try:
        conn = RawConn(port)
    except OSError:
        return
    i = 0
    while not stop.is_set():
        board = BOARDS[i % 2]
        msg = Message(
            type=f"Dur.P{poster}.N{i}",
            sender=f"Storm{poster}",
            to=board,
            posted=now(),
            priority=2.0,
            content=f"{poster}/{i}",
        )
        try:
            conn.send(msg)
            reply = conn.recv(WAIT)
        except (OSError, AssertionError, TimeoutError):
            break
        if reply.type == "RECEIVE_ACCEPT" and reply.isresponse == msg.id:
            acked.add(board, msg.id)
        i += 1
    conn.close()


def retrieve_all(port: int, board: str) -> list[Message]:
    """Every stored `Dur.*` message of `board`, newest first (latest 0, OA-RET-4)."""
    conn = RawConn(port)
    spec = f'<retrieve from="{board}" type="Dur.*"><latest>0</latest></retrieve>'
    msg = Message(
        type="AIR.Retrieve",
        sender="Checker",
        to=board,
        posted=now(),
        content=spec,
        content_is_xml=True,
        language="xml",
    )
    reply = conn.request(msg)
    conn.close()
    assert reply.type == "AIR.Retrieve.Success", (reply.type, reply.content)
    return collection_messages(reply)


def check_history(port: int, acked: list[tuple[str, str]], posted_in_order: bool) -> None:
    """Every acknowledged post is stored, wbids unique and newest first, per-poster order kept."""
    for board in BOARDS:
        stored = retrieve_all(port, board)
        wbids = [m.wbid for m in stored]
        assert all(w is not None for w in wbids)
        assert wbids == sorted(wbids, reverse=True) and len(set(wbids)) == len(wbids), wbids
        position = {m.id: i for i, m in enumerate(stored)}
        want = [mid for b, mid in acked if b == board]
        lost = [mid for mid in want if mid not in position]
        assert not lost, f"{board}: {len(lost)} acknowledged posts lost (OA-ERR-5, OA-WB-9)"
        if posted_in_order:
            by_poster: dict[str, list[int]] = {}
            for m in stored:
                if m.id in want:
                    by_poster.setdefault(m.sender, []).append(position[m.id])
            for poster, places in by_poster.items():
                assert places == sorted(places), f"{board}/{poster}: order broken (OA-WB-12)"


def run_storm(server: ServerProcess) -> tuple[Acks, list[threading.Thread], threading.Event]:
    """Start the posters; return their acknowledgements, threads and stop flag."""
    acked = Acks()
    stop = threading.Event()
    threads = [
        threading.Thread(target=storm, args=(server.port, p, acked, stop), daemon=True)
        for p in range(POSTERS)
    ]
    for t in threads:
        t.start()
    return acked, threads, stop


def test_durable_capability_advertised(store: Path) -> None:
    """A server with a durable store advertises `durable` (OA-CAP-3, OA-WB-9)."""
    server = ServerProcess(store)
    try:
        conn = RawConn(server.port)
        reply = conn.request(Message(type="GET_CAPABILITIES", sender="Checker", posted=now()))
        conn.close()
        roots = content_elements(reply)
        assert reply.type == "CAPABILITIES" and local_name(roots[0]) == "capabilities"
        names = {e.get("name") for e in roots[0] if isinstance(e.tag, str)}
        assert "durable" in names, names
    finally:
        server.stop()


def test_kill_mid_storm_loses_no_acknowledged_post(store: Path) -> None:
    server = ServerProcess(store)
    try:
        acked, threads, stop = run_storm(server)
        reached = acked.wait_for(KILL_AFTER)
        server.signal(signal.SIGKILL)  # in the middle of the storm: posters are mid-request
        stop.set()
        for t in threads:
            t.join(WAIT)
        assert reached, f"only {len(acked.snapshot())} posts acknowledged before the deadline"
    finally:
        server.stop()
    snapshot = acked.snapshot()
    again = ServerProcess(store)
    try:
        check_history(again.port, snapshot, posted_in_order=True)
        check_sequence_continues(again.port)
    finally:
        again.stop()


def test_sigterm_keeps_everything_acknowledged(store: Path) -> None:
    server = ServerProcess(store)
    try:
        acked, threads, stop = run_storm(server)
        assert acked.wait_for(40), len(acked.snapshot())
        stop.set()
        for t in threads:
            t.join(WAIT)
        assert server.signal(signal.SIGTERM) == 0, "graceful stop must exit 0 (openair serve)"
    finally:
        server.stop()
    again = ServerProcess(store)
    try:
        check_history(again.port, acked.snapshot(), posted_in_order=True)
    finally:
        again.stop()


def check_sequence_continues(port: int) -> None:
    """A post after the restart gets a wbid above every stored one (OA-WB-9, OA-WB-5)."""
    before = max((m.wbid or 0) for m in retrieve_all(port, "WB1"))
    conn = RawConn(port)
    msg = Message(type="Dur.After", sender="Checker", to="WB1", posted=now(), content="after")
    assert conn.request(msg).type == "RECEIVE_ACCEPT"
    conn.close()
    newest = retrieve_all(port, "WB1")[0]
    assert newest.id == msg.id and (newest.wbid or 0) > before, (newest.wbid, before)


if os.name != "posix":  # SIGKILL and SIGTERM semantics are POSIX
    pytestmark = pytest.mark.skip(reason="POSIX signals")
