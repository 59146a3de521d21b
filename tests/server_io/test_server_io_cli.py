"""`openair serve`: readiness line, configuration errors, exit codes, SIGTERM."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner

from openair.protocol.codec import from_frame, to_frame
from openair.protocol.datasample import DataSample, encode_chunk
from openair.protocol.framing import FrameReader, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.server.cli_serve import serve


def test_help_documents_the_exit_codes() -> None:
    result = CliRunner().invoke(serve, ["--help"])
    assert result.exit_code == 0
    assert "Exit codes" in result.output
    assert "--store" in result.output and "--config" in result.output


def test_an_invalid_configuration_exits_2_naming_file_and_line(tmp_path: Path) -> None:
    spec = tmp_path / "bad.xml"
    spec.write_text('<psySpec name="x">\n  <whiteboard name="WB1">\n</psySpec>\n')
    result = CliRunner().invoke(serve, ["--port", "0", "--config", str(spec)])
    assert result.exit_code == 2
    assert f"{spec}:" in result.output


def test_an_unknown_store_exits_2() -> None:
    result = CliRunner().invoke(serve, ["--port", "0", "--store", "floppy"])
    assert result.exit_code == 2
    assert "floppy" in result.output


def test_serve_announces_its_port_serves_and_stops_on_sigterm() -> None:
    code = "from openair.server.cli_serve import serve; serve()"
    argv = [sys.executable, "-c", code, "--port", "0", "--log-level", "warning"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line.startswith("listening on 127.0.0.1:"), line
        assert "(whiteboards: AIRCentral, WB1, WB2)" in line
        port = int(line.split(":", 1)[1].split()[0])
        with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
            ping = Message(type="PING", to="CNS", sender="CliTest")
            sock.sendall(encode_frame(to_frame(ping)))
            reader = FrameReader()
            while (frame := reader.next_frame()) is None:
                reader.feed(sock.recv(65536))
            assert from_frame(frame).isresponse == ping.id
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _recv(sock: socket.socket, reader: FrameReader) -> Message:
    while (frame := reader.next_frame()) is None:
        data = sock.recv(65536)
        assert data, "the server closed the connection"
        reader.feed(data)
    return from_frame(frame)


def test_stream_options_reach_the_server() -> None:
    """--stream-push-buffer bounds a push reader's buffer; --max-wait-ms clips waits."""
    code = "from openair.server.cli_serve import serve; serve()"
    argv = [sys.executable, "-c", code, "--port", "0", "--log-level", "warning", "--no-monitor"]
    argv += ["--stream-push-buffer", "2", "--max-wait-ms", "50"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        port = int(proc.stdout.readline().split(":", 1)[1].split()[0])
        with (
            socket.create_connection(("127.0.0.1", port), timeout=20) as push,
            socket.create_connection(("127.0.0.1", port), timeout=20) as writer,
        ):
            note = Message(type="RECEIVE_NAME_NOTIFICATION", to="Stream1", sender="Slow")
            push.sendall(encode_frame(to_frame(note, FrameTag.RECEIVE)))
            wreader, preader = FrameReader(), FrameReader()
            ping = Message(type="PING", to="CNS", sender="W")
            writer.sendall(encode_frame(to_frame(ping)))
            assert _recv(writer, wreader).type == "PING_SUCCESS"
            for n in range(6):
                add = Message(
                    type="ADD_SAMPLE",
                    to="Stream1",
                    sender="W",
                    content="<datasample/>",
                    content_is_xml=True,
                    binary=(encode_chunk(DataSample(payload=bytes([n]))),),
                )
                writer.sendall(encode_frame(to_frame(add)))
                assert _recv(writer, wreader).type == "DATA_ACCEPTED"
            first = _recv(push, preader)  # sample 0 in flight, never acknowledged until now
            push.sendall(encode_frame(to_frame(first.reply("RECEIVE_ACCEPT", sender="Slow"))))
            resumed = _recv(push, preader)
            dropped = resumed.extra("dropped")
            assert dropped is not None and dropped.value == "3"  # 5 waiting, buffer of 2
            # A wait of an hour is clipped to 50 ms: SAMPLE_UNKNOWN comes back soon.
            wait = Message(
                type="WAIT_FOR_FIRST_AFTERID 3600000", to="Stream1", sender="W", content="999"
            )
            writer.sendall(encode_frame(to_frame(wait)))
            answer = _recv(writer, wreader)
            assert answer.type == "RECEIVE_ERROR" and answer.content.startswith("SAMPLE_UNKNOWN")
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
