"""`openair stream ls|tail|push` through click's CliRunner, against a server in a thread."""

from __future__ import annotations

import asyncio
import itertools
import json
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from client_helpers import ServerThread
from streams_support import config, module

from openair.cli import main
from openair.client.cli_client import EXIT_CONNECT, EXIT_FAILED, EXIT_USAGE
from openair.client.cli_stream import (
    chunks_of,
    ls,
    push,
    sample_line,
    sample_record,
    stream,
    table,
    tail,
)
from openair.client.stream_wire import ReceivedSample
from openair.protocol.datasample import DataSample


@pytest.fixture(scope="module")
def srv() -> Iterator[ServerThread]:
    thread = ServerThread(config=config(), monitor=False)
    try:
        yield thread
    finally:
        thread.stop()


def addr(srv: ServerThread) -> list[str]:
    return ["--server", f"127.0.0.1:{srv.port}"]


async def read_all(port: int, target: str) -> list[DataSample]:
    """Every sample a stream holds, oldest first (read from the server's loop)."""
    async with module("CliCheck", port, bind=False) as m:
        handle = m.stream(target)
        return await handle.between(0, 2**62)


async def count(port: int, target: str) -> int:
    async with module("CliCheck", port, bind=False) as m:
        return await m.stream(target).count()


def test_stream_group_is_registered() -> None:
    assert main.commands["stream"] is stream
    assert sorted(stream.commands) == ["ls", "push", "tail"]
    for command in stream.commands.values():
        assert "Exit codes" in (command.epilog or "")


def test_chunks_are_views_of_the_file() -> None:
    data = b"abcdefghij"
    assert [bytes(c) for c in chunks_of(data, 4)] == [b"abcd", b"efgh", b"ij"]
    assert [bytes(c) for c in chunks_of(data, None)] == [data]
    assert [bytes(c) for c in chunks_of(data, 50)] == [data]
    assert all(c.obj is data for c in chunks_of(data, 3))  # no copy


def test_table_aligns_columns() -> None:
    lines = table([("a", "bbb"), ("cccc", "d")], header=("X", "Y"))
    assert lines == ["X     Y", "a     bbb", "cccc  d"]


def test_push_splits_the_file_and_numbers_the_samples(srv: ServerThread, tmp_path: Path) -> None:
    file = tmp_path / "audio.raw"
    file.write_bytes(b"0123456789")
    args = ["Stream2", str(file), "--rate", "0", "--chunk", "3", "--param", "src=cli"]
    result = CliRunner().invoke(push, [*args, *addr(srv)])
    assert result.exit_code == 0, result.output
    assert "pushed 4 samples (10 bytes) to Stream2" in result.output
    assert "4 acks, 0 refused" in result.output
    held = srv.call(read_all(srv.port, "Stream2"))[-4:]
    assert [bytes(s.payload) for s in held] == [b"012", b"345", b"678", b"9"]
    assert [s.seq for s in held] == [1, 2, 3, 4]
    assert all(s.param("src") == "cli" for s in held)


def test_push_binary_loop_and_count(srv: ServerThread, tmp_path: Path) -> None:
    file = tmp_path / "frame.bin"
    file.write_bytes(b"AB")
    before = srv.call(count(srv.port, "Stream1"))
    args = ["Input.Audio.Perception", str(file), "--rate", "1000", "--chunk", "1", "--loop",
            "--count", "5", "--binary"]  # fmt: skip
    result = CliRunner().invoke(push, [*args, *addr(srv)])
    assert result.exit_code == 0, result.output
    assert "pushed 5 samples (5 bytes)" in result.output and "5 acks" in result.output
    held = srv.call(read_all(srv.port, "Audio"))[-5:]
    assert [bytes(s.payload) for s in held] == [b"A", b"B", b"A", b"B", b"A"]
    assert [s.seq for s in held] == [1, 2, 3, 4, 5]
    assert srv.call(count(srv.port, "Stream1")) == before  # only the named stream grew


def test_push_failures_and_usage(srv: ServerThread, tmp_path: Path) -> None:
    file = tmp_path / "big.bin"
    file.write_bytes(b"x" * 200)
    runner = CliRunner()
    refused = runner.invoke(push, ["Tiny", str(file), "--rate", "0", *addr(srv)])
    assert refused.exit_code == EXIT_FAILED, refused.output
    assert "1 refused" in refused.output and "SAMPLE_INVALID" in refused.output
    unknown = runner.invoke(push, ["NoSuchStream", str(file), "--rate", "0", *addr(srv)])
    assert unknown.exit_code == EXIT_FAILED and "STREAM_UNKNOWN" in unknown.output
    missing = runner.invoke(push, ["Stream1", str(tmp_path / "none"), "--rate", "1", *addr(srv)])
    assert missing.exit_code == EXIT_USAGE
    bad_param = runner.invoke(push, ["Stream1", str(file), "--rate", "1", "--param", "novalue"])
    assert bad_param.exit_code == EXIT_USAGE
    no_rate = runner.invoke(push, ["Stream1", str(file), *addr(srv)])
    assert no_rate.exit_code == EXIT_USAGE


def test_ls_lists_streams_with_fill(srv: ServerThread, tmp_path: Path) -> None:
    file = tmp_path / "one.bin"
    file.write_bytes(b"r" * 10)
    assert CliRunner().invoke(push, ["Ring", str(file), "--rate", "0", *addr(srv)]).exit_code == 0
    as_json = CliRunner().invoke(ls, ["--json", *addr(srv)])
    assert as_json.exit_code == 0, as_json.output
    infos = json.loads(as_json.output)
    assert [i["name"] for i in infos] == ["Stream1", "Audio", "Ring", "Tiny", "Stream2"]
    ring = infos[2]
    assert (ring["type"], ring["whiteboard"], ring["hardcount"]) == ("Test.Stream.Ring", "WB1", 5)
    held = ring["count"]
    text = CliRunner().invoke(ls, addr(srv))
    assert text.exit_code == 0, text.output
    header, *rows = text.output.splitlines()
    assert header.split() == ["NAME", "WHITEBOARD", "TYPE", "COUNT", "SIZE", "FILL", "SUBSCRIBERS"]
    ring_row = next(r for r in rows if r.startswith("Ring "))
    assert "Test.Stream.Ring" in ring_row and f"{held}/5 samples" in ring_row


def test_commands_report_connection_failures() -> None:
    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        dead = ["--server", f"127.0.0.1:{sock.getsockname()[1]}"]
    assert CliRunner().invoke(ls, dead).exit_code == EXIT_CONNECT
    assert CliRunner().invoke(tail, ["Stream1", *dead]).exit_code == EXIT_CONNECT


def test_tail_prints_one_line_per_sample(srv: ServerThread) -> None:
    stop = threading.Event()
    written: list[int] = []

    async def keep_writing() -> None:
        """Write until the tail is done; the tail sees whatever follows its subscription."""
        async with module("CliWriter", srv.port, bind=False) as m:
            handle = m.stream("Stream1")
            while not stop.is_set():
                seq = len(written) + 1
                written.append(await handle.add(b"tick", {"n": str(seq)}, seq=seq) or 0)
                await asyncio.sleep(0.002)  # pacing only: the test waits on the tail's count

    writer = threading.Thread(target=asyncio.run, args=(keep_writing(),))
    writer.start()
    try:
        result = CliRunner().invoke(tail, ["Stream1", "--count", "3", "--json", *addr(srv)])
    finally:
        stop.set()
        writer.join(30)
    assert result.exit_code == 0, result.output
    records = [json.loads(line) for line in result.output.splitlines()]
    assert len(records) == 3
    assert all(r["stream"] == "Stream1" and r["size"] == 4 for r in records)
    assert all(r["params"]["n"] == r["params"]["builtin:seq"] for r in records)
    assert all(r["id"] in written for r in records)
    for before, after in itertools.pairwise(records):
        assert after["id"] - before["id"] == 1 + after["dropped"]


def test_tail_unknown_stream_fails(srv: ServerThread) -> None:
    refused = CliRunner().invoke(tail, ["NoSuchStream", *addr(srv)])
    assert refused.exit_code == EXIT_FAILED and "STREAM_UNKNOWN" in refused.output


def test_sample_line_and_record() -> None:
    sample = DataSample(
        payload=b"12345",
        params=(("builtin:id", "7"), ("builtin:timestamp", "99"), ("k", "v"), ("z", "")),
    )
    got = ReceivedSample(stream="Audio", sample=sample, dropped=2)
    assert sample_line(got) == "id=7 timestamp=99 size=5 params=k=v,z= dropped=2"
    assert sample_record(got) == {
        "stream": "Audio", "id": 7, "timestamp": 99, "size": 5,
        "params": {"k": "v", "z": ""}, "dropped": 2,
    }  # fmt: skip
    bare = ReceivedSample(stream="S", sample=DataSample(payload=b""))
    assert sample_line(bare) == "id=None timestamp=None size=0 params=- dropped=0"
