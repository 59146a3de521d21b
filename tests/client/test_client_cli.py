"""The client commands (post, retrieve, ping, watch) through click's CliRunner."""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator

import pytest
from click.testing import CliRunner
from client_helpers import ServerThread

from openair.client import Module, WakeupEvent
from openair.client.cli_client import (
    COMMANDS,
    EXIT_CONNECT,
    EXIT_FAILED,
    EXIT_USAGE,
    parse_server,
    ping,
    post,
    retrieve,
    watch,
)


@pytest.fixture(scope="module")
def srv() -> Iterator[ServerThread]:
    thread = ServerThread()
    try:
        yield thread
    finally:
        thread.stop()


def addr(srv: ServerThread) -> str:
    return f"127.0.0.1:{srv.port}"


def test_commands_are_exposed() -> None:
    assert [c.name for c in COMMANDS] == ["post", "watch", "retrieve", "ping"]
    for command in COMMANDS:
        assert "Exit codes" in (command.epilog or "")


@pytest.mark.parametrize(
    ("text", "expected"),
    [("h:1", ("h", 1)), ("h", ("h", 10000)), (":5", ("127.0.0.1", 5)), ("[::1]:7", ("::1", 7))],
)
def test_parse_server(text: str, expected: tuple[str, int]) -> None:
    assert parse_server(text) == expected


@pytest.mark.parametrize("text", ["h:x", "h:0", "h:70000"])
def test_parse_server_rejects(text: str) -> None:
    with pytest.raises(ValueError):
        parse_server(text)


def test_ping_lists_capabilities(srv: ServerThread) -> None:
    result = CliRunner().invoke(ping, [addr(srv), "--count", "2"])
    assert result.exit_code == 0, result.output
    assert result.output.count("PING_SUCCESS") == 2
    assert "protocol=OpenAIR/1.0" in result.output
    assert "pipelining" in result.output


def test_post_then_retrieve(srv: ServerThread) -> None:
    runner = CliRunner()
    server = ["--server", addr(srv)]
    first = runner.invoke(post, ["WB2", "Cli.Post.A", "alpha", "--from", "CliPoster", *server])
    assert first.exit_code == 0, first.output
    second = runner.invoke(post, ["WB2", "Cli.Post.B", "<x a='1'/>", "--xml", *server])
    assert second.exit_code == 0, second.output
    query = ["WB2", "--type", "Cli.Post.*", "--latest", "0", "--json"]
    found = runner.invoke(retrieve, [*query, *server])
    assert found.exit_code == 0, found.output
    messages = json.loads(found.output)
    assert [m["type"] for m in messages] == ["Cli.Post.B", "Cli.Post.A"]
    assert messages[1]["content"] == "alpha" and messages[1]["from"] == "CliPoster"
    assert messages[1]["stored"] == "WB2" and messages[1]["receivedTime"] is not None
    plain = runner.invoke(retrieve, ["WB2", "--sender", "CliPoster", *server])
    assert plain.exit_code == 0
    assert "Cli.Post.A from=CliPoster" in plain.output and "'alpha'" in plain.output


def test_usage_errors_exit_2(srv: ServerThread) -> None:
    runner = CliRunner()
    server = ["--server", addr(srv)]
    assert runner.invoke(post, ["WB1", "Bad*Type", *server]).exit_code == EXIT_USAGE
    assert runner.invoke(post, ["WB1", "Cli.X", "<open>", "--xml", *server]).exit_code == EXIT_USAGE
    assert runner.invoke(post, ["WB1", "Cli.X", "--priority", "9", *server]).exit_code == EXIT_USAGE
    assert runner.invoke(retrieve, ["WB1", "--type", "A.**", *server]).exit_code == EXIT_USAGE
    assert runner.invoke(ping, ["host:notaport"]).exit_code == EXIT_USAGE


def test_failed_request_exits_1(srv: ServerThread) -> None:
    result = CliRunner().invoke(post, ["NoSuchWB", "Cli.Lost", "--server", addr(srv)])
    assert result.exit_code == EXIT_FAILED
    assert "FORWARD_FAILED" in result.output
    result = CliRunner().invoke(retrieve, ["NoSuchWB", "--server", addr(srv)])
    assert result.exit_code == EXIT_FAILED


def test_cannot_connect_exits_3() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # bound, not listening: connections are refused
        result = CliRunner().invoke(ping, [f"127.0.0.1:{port}"])
    assert result.exit_code == EXIT_CONNECT
    assert "cannot connect" in result.output


def test_watch_prints_one_line_per_wakeup(srv: ServerThread) -> None:
    name = "cli-watch"

    async def start_helper() -> Module:
        """A module on the server's loop: once `watch` announces itself, cc it a message."""

        async def on_wakeup(event: WakeupEvent) -> None:
            trigger = event.wakeup.trigger
            if trigger is not None and trigger.type == f"Psyclone.Module.Connect.{name}":
                await helper.post("WB1", "Cli.Watch.Hello", "hi", cc=[name])

        helper = Module("cli-helper", port=srv.port, keepalive=None, on_wakeup=on_wakeup)
        await helper.connect()
        await helper.subscribe(f"Psyclone.Module.Connect.{name}")
        return helper

    helper = srv.call(start_helper())
    try:
        result = CliRunner().invoke(
            watch, ["Cli.Watch.*", "--count", "1", "--name", name, "--server", addr(srv)]
        )
    finally:
        srv.call(helper.close())
    assert result.exit_code == 0, result.output
    (line,) = result.output.splitlines()
    assert line.startswith("Cli.Watch.Hello from=cli-helper wb=WB1 posted=")
    assert " stored=" in line and " woken=" in line and " latency_ms=" in line
