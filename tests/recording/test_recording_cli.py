"""`openair record` stopped by SIGTERM or --duration, `openair replay`, the monitor's JSON API."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from server_thread import ReferenceServer

from openair.cli import main
from openair.client import BlockingModule
from openair.protocol.content import RetrieveSpec
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair_monitor.http import HttpError, Request
from openair_recording import Header, RecordingReader, RecordingWriter, read_index
from openair_recording.monitor import RecordingMonitor

OPENAIR = [sys.executable, "-m", "openair.cli"]


@pytest.fixture
def reference() -> Iterator[ReferenceServer]:
    srv = ReferenceServer()
    try:
        yield srv
    finally:
        srv.stop()


def start_recording(port: int, path: Path, *extra: str) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [*OPENAIR, "record", f"127.0.0.1:{port}", "-o", str(path), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stderr is not None
    line = proc.stderr.readline()  # said once the module is subscribed
    assert line.startswith("recording "), line + proc.stderr.read()
    return proc


def test_sigterm_stops_the_recorder_with_a_complete_file(
    reference: ReferenceServer, tmp_path: Path
) -> None:
    path = tmp_path / "r.oair"
    proc = start_recording(reference.port, path)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert out.startswith("recorded ") and str(path) in out
    reader = RecordingReader.open(path)
    list(reader.records())
    assert reader.complete and reader.warnings == [] and read_index(path) is not None
    assert {"WB1", "WB2"} <= set(reader.header.whiteboards)
    assert {s["name"] for s in reader.header.streams} == {"Stream1", "Stream2"}


def test_duration_stops_the_recorder(reference: ReferenceServer, tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    proc = start_recording(reference.port, path, "--duration", "0.2", "--streams", "Stream1,Nope")
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "no stream 'Nope'" in err
    reader = RecordingReader.open(path)
    list(reader.records())
    assert reader.complete
    assert [s["name"] for s in reader.header.streams] == ["Stream1"]


def test_record_to_a_closed_port_exits_3(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["record", "127.0.0.1:1", "-o", str(tmp_path / "x")])
    assert result.exit_code == 3, result.output


def recording(path: Path) -> list[Message]:
    posted = AirTime(sec=1_800_000_000, msec=5, usec=7)
    msgs = [
        Message(
            type=f"Cli.T{i}",
            sender="Orig",
            to=wb,
            stored=wb,
            wbid=i,
            posted=posted,
            received=AirTime.from_ms(posted.ms + 10 * i),
            content=f"c{i}",
            binary=(bytes([i]) * 5,),
            priority=1.0 + i,
        )
        for i, wb in enumerate(["WB1", "WB2", "WB1"], start=1)
    ]
    writer = RecordingWriter(path, Header(whiteboards=("WB1", "WB2")))
    for m in msgs:
        writer.add_message(m, 0)
    writer.close(0)
    return msgs


def test_the_replay_command_posts_with_the_original_time(
    reference: ReferenceServer, tmp_path: Path
) -> None:
    path = tmp_path / "r.oair"
    msgs = recording(path)
    args = ["replay", str(path), "--to", f"127.0.0.1:{reference.port}", "--speed", "0"]
    result = CliRunner().invoke(main, [*args, "--types", "Cli.*", "--until", "0.015"])
    assert result.exit_code == 0, result.output
    assert "replayed 2 messages" in result.output  # T3 is 20 ms after the first
    with BlockingModule("Check", port=reference.port, bind=False) as m:
        found = m.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Cli.*", latest=0))
    assert [(f.type, f.binary, f.priority) for f in found] == [("Cli.T1", (b"\x01" * 5,), 2.0)]
    slot = found[0].extra("originalPostedTime")
    assert slot is not None and slot.value == str(msgs[0].posted) == "1800000000.005007"


def get(app: RecordingMonitor, target: str) -> tuple[int, bytes]:
    try:
        response = app.respond(Request(method="GET", target=target), "127.0.0.1")
    except HttpError as exc:  # the connection answers its status
        return exc.status, b""
    return response.status, response.body


def test_the_monitor_api_reads_a_recording(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    msgs = recording(path)
    reader = RecordingReader.open(path)
    app = RecordingMonitor(str(path), reader.header, list(reader.records()))
    status, body = get(app, "/api/whiteboards/WB1/messages?pattern=Cli.*")
    listed = json.loads(body)
    assert status == 200 and [m["type"] for m in listed["messages"]] == ["Cli.T3", "Cli.T1"]
    assert listed["messages"][0]["attachments"] == 1
    status, body = get(app, "/api/messages/WB2/2")
    detail = json.loads(body)
    assert status == 200 and detail["slots"]["content"] == "c2"
    assert detail["slots"]["postedTime"]["text"] == str(msgs[1].posted)
    assert get(app, "/api/messages/WB1/3/attachments/1") == (200, b"\x03" * 5)
    overview = json.loads(get(app, "/api/overview")[1])
    assert overview["recording"]["messages"] == 3
    assert [w["count"] for w in overview["whiteboards"]] == [2, 1]
    assert get(app, "/api/whiteboards/Nope/messages")[0] == 404
    assert get(app, "/api/whiteboards/WB1/messages?pattern=a..b")[0] == 400
    assert get(app, "/api/events")[0] == 404


def test_openair_monitor_serves_the_api_until_sigterm(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    recording(path)
    proc = subprocess.Popen(
        [*OPENAIR, "monitor", str(path), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        assert line.startswith("monitor of "), line + proc.stderr.read()
        url = line.split()[-1]
        with urllib.request.urlopen(url + "whiteboards", timeout=10) as response:
            boards = json.loads(response.read())["whiteboards"]
        assert [(b["name"], b["count"]) for b in boards] == [("WB1", 2), ("WB2", 1)]
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
