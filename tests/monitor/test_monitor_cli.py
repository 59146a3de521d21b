"""`openair serve` monitor options: --http-port, --monitor-post, --monitor-host, --no-monitor."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import urllib.request

from click.testing import CliRunner

from openair.server.cli_serve import serve


def test_no_monitor_with_other_monitor_options_is_a_usage_error() -> None:
    result = CliRunner().invoke(serve, ["--no-monitor", "--monitor-post"])
    assert result.exit_code == 2
    assert "--no-monitor" in result.output


def test_an_http_port_in_use_is_exit_1() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        args = ["--port", "0", "--http-port", str(port), "--log-level", "error"]
        result = CliRunner().invoke(serve, args)
    assert result.exit_code == 1
    assert "cannot start" in result.output


def test_serve_prints_where_the_monitor_answers_and_passes_the_options() -> None:
    argv = [
        sys.executable, "-c", "from openair.cli import main; main()", "serve", "--port", "0",
        "--http-port", "0", "--monitor-post", "--monitor-host", "10.0.0.5",
        "--log-level", "warning",
    ]  # fmt: skip
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().startswith("listening on 127.0.0.1:")
        line = proc.stdout.readline()
        assert line.startswith("monitor on http://127.0.0.1:") and "(posting allowed)" in line
        urls = [word for word in line.split() if word.startswith("http://")]
        assert len(urls) == 2  # the main port and the HTTP port
        with urllib.request.urlopen(urls[1] + "api/overview", timeout=10) as reply:
            server = json.load(reply)["server"]
        assert server["post_enabled"] is True
        assert server["post_hosts"] == sorted(["127.0.0.1", "::1", "10.0.0.5"])
        assert server["http_port"] == int(urls[1].rsplit(":", 1)[1].rstrip("/"))
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=20)
    assert proc.returncode == 0
