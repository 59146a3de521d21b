"""The client commands as users run them (issue #18): large content, content on screen and in
JSON, --timeout, peers that are not OpenAIR, unknown whiteboards, `ping --server`."""

from __future__ import annotations

import contextlib
import json
import socket
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from product_support import openair_command
from server_thread import ReferenceServer

from openair.cli import main
from openair.client import Module, WakeupEvent
from openair.client.cli_client import EXIT_CONNECT, EXIT_FAILED, EXIT_USAGE, SHOWN_CHARS

_BIG = 200 * 1024  # over the ~128 KiB one shell argument may hold


@pytest.fixture(scope="module")
def srv() -> Iterator[ReferenceServer]:
    server = ReferenceServer()
    try:
        yield server
    finally:
        server.stop()


def _at(srv: ReferenceServer) -> list[str]:
    return ["--server", f"127.0.0.1:{srv.port}"]


def _invoke(*args: str, stdin: str | None = None) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args), input=stdin)
    return result.exit_code, result.output


def _retrieve_json(srv: ReferenceServer, type_: str) -> list[dict[str, object]]:
    code, out = _invoke("retrieve", "WB1", "--type", type_, "--json", *_at(srv))
    assert code == 0, out
    found: list[dict[str, object]] = json.loads(out)
    return found


def test_post_file_carries_large_content(srv: ReferenceServer, tmp_path: Path) -> None:
    path = tmp_path / "big.txt"
    path.write_text("x" * _BIG, encoding="utf-8")
    code, out = _invoke("post", "WB1", "Cli.File.Big", "--file", str(path), *_at(srv))
    assert code == 0, out
    (stored,) = _retrieve_json(srv, "Cli.File.Big")
    assert stored["content"] == "x" * _BIG


def test_post_file_dash_reads_stdin(srv: ReferenceServer) -> None:
    code, out = _invoke("post", "WB1", "Cli.File.Stdin", "--file", "-", *_at(srv), stdin="héllo\n")
    assert code == 0, out
    (stored,) = _retrieve_json(srv, "Cli.File.Stdin")
    assert stored["content"] == "héllo\n"


def test_post_content_and_file_is_a_usage_error(srv: ReferenceServer, tmp_path: Path) -> None:
    path = tmp_path / "c.txt"
    path.write_text("c", encoding="utf-8")
    code, _ = _invoke("post", "WB1", "Cli.File.Both", "text", "--file", str(path), *_at(srv))
    assert code == EXIT_USAGE
    code, _ = _invoke("post", "WB1", "Cli.File.None", "--file", str(tmp_path / "no"), *_at(srv))
    assert code == EXIT_USAGE


def test_retrieve_cuts_long_content_unless_full(srv: ReferenceServer) -> None:
    content = "abc" * 1000
    assert _invoke("post", "WB1", "Cli.Long.One", content, *_at(srv))[0] == 0
    code, out = _invoke("retrieve", "WB1", "--type", "Cli.Long.One", *_at(srv))
    assert code == 0, out
    assert content not in out
    assert repr(content[:SHOWN_CHARS]) in out
    assert f"[{len(content)} characters; --full shows all]" in out
    code, out = _invoke("retrieve", "WB1", "--type", "Cli.Long.One", "--full", *_at(srv))
    assert code == 0 and repr(content) in out


def test_post_to_an_unknown_whiteboard_says_so(srv: ReferenceServer) -> None:
    code, out = _invoke("post", "NoSuchWB", "Cli.Lost", "x", *_at(srv))
    assert code == EXIT_FAILED
    assert "'NoSuchWB' is no whiteboard, component, stream or bound module" in out
    assert "FORWARD_FAILED" in out  # the condition of OA-SESS-21


def test_watch_from_an_unknown_whiteboard_fails_at_once(srv: ReferenceServer) -> None:
    # A real process: before the fix it waited for ever (the timeout fails the test).
    done = subprocess.run(
        [*openair_command(), "watch", "Cli.*", "--from", "NoSuchWB", *_at(srv)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == EXIT_FAILED
    assert "no whiteboard 'NoSuchWB'" in done.stderr


def _watch_once(srv: ReferenceServer, name: str, content: str, *options: str) -> str:
    """Run `watch --count 1 OPTIONS`; a helper cc's it one message once it has connected."""

    async def start_helper() -> Module:
        async def on_wakeup(event: WakeupEvent) -> None:
            trigger = event.wakeup.trigger
            if trigger is not None and trigger.type == f"Psyclone.Module.Connect.{name}":
                await helper.post("WB1", "Cli.Watch.Shown", content, cc=[name])

        helper = Module(f"{name}-helper", port=srv.port, keepalive=None, on_wakeup=on_wakeup)
        await helper.connect()
        await helper.subscribe(f"Psyclone.Module.Connect.{name}")
        return helper

    helper = srv.call(start_helper())
    try:
        code, out = _invoke(
            "watch", "Cli.Watch.*", "--count", "1", "--name", name, *options, *_at(srv)
        )
    finally:
        srv.call(helper.close())
    assert code == 0, out
    return out


def test_watch_shows_content_cut(srv: ReferenceServer) -> None:
    content = "word " * 100
    (line,) = _watch_once(srv, "cli-watch-line", content).splitlines()
    assert line.startswith("Cli.Watch.Shown from=cli-watch-line-helper wb=WB1 ")
    assert repr(content[: SHOWN_CHARS // 2]) in line
    assert f"[{len(content)} characters; --full shows all]" in line


def test_watch_json_is_one_object_per_line(srv: ReferenceServer) -> None:
    content = "<b>" + "z" * 500
    (line,) = _watch_once(srv, "cli-watch-json", content, "--json").splitlines()
    record = json.loads(line)
    assert record["type"] == "Cli.Watch.Shown"
    assert record["content"] == content
    assert record["whiteboard"] == "WB1"
    assert record["from"] == "cli-watch-json-helper"
    assert set(record["wokenTime"]) == {"sec", "msec", "usec"}


def test_ping_takes_server_and_keeps_the_argument(srv: ReferenceServer) -> None:
    code, out = _invoke("ping", *_at(srv))
    assert code == 0 and "PING_SUCCESS" in out
    code, out = _invoke("ping", f"127.0.0.1:{srv.port}")
    assert code == 0 and "PING_SUCCESS" in out
    code, _ = _invoke("ping", f"127.0.0.1:{srv.port}", *_at(srv))
    assert code == EXIT_USAGE


class _NotOpenAIR:
    """A TCP peer that is not OpenAIR: silent, or answering every connection with `banner`."""

    def __init__(self, banner: bytes | None) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = int(self.sock.getsockname()[1])
        self._banner = banner
        self._held: list[socket.socket] = []
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return  # closed
            if self._banner is not None:
                conn.sendall(self._banner)
            self._held.append(conn)

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)  # wakes the accept() (close alone does not)
        self.sock.close()
        for conn in self._held:
            conn.close()
        self._thread.join(10)


@pytest.mark.parametrize(
    "banner", [None, b"HTTP/1.1 400 Bad Request\r\n\r\n", b"SSH-2.0-OpenSSH_9.6\r\n"]
)
@pytest.mark.parametrize(
    "command", [("ping",), ("post", "WB1", "Cli.X", "x"), ("retrieve", "WB1"), ("stream", "ls")]
)
def test_a_peer_that_is_not_openair_exits_3(banner: bytes | None, command: tuple[str, ...]) -> None:
    peer = _NotOpenAIR(banner)
    try:
        code, out = _invoke(*command, "--server", f"127.0.0.1:{peer.port}", "--timeout", "0.5")
    finally:
        peer.close()
    assert code == EXIT_CONNECT, out
    assert f"127.0.0.1:{peer.port} is not an OpenAIR server" in out
