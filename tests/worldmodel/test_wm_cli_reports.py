"""`openair conform-worldmodel` on the one engine: the reporters of `openair conform`, the same
verdicts and exit codes (issue #17), against the reference world model and against nobody."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner
from server_thread import ServerThread

from openair.cli import main
from openair.server.aio.app import ServerOptions, start_server
from openair_conformance.worldmodel import CASES
from openair_worldmodel.node import WorldModelNode


def _serve() -> ServerThread:
    return ServerThread(lambda: start_server(ServerOptions(port=0, monitor=False)))


def test_reports_of_a_passing_module(tmp_path: Path) -> None:
    thread = _serve()
    node = WorldModelNode("WMImpl", robot="R", whiteboard="WB1", port=thread.port)
    try:
        thread.call(node.start())
        report, junit = tmp_path / "wm.json", tmp_path / "wm.xml"
        done = CliRunner().invoke(
            main,
            ["conform-worldmodel", f"127.0.0.1:{thread.port}", "--module", "WMImpl", "--bound",
             "20", "--json", str(report), "--junit", str(junit)],
        )  # fmt: skip
    finally:
        thread.call(node.close())
        thread.stop()
    assert done.exit_code == 0, done.output
    data = json.loads(report.read_text())
    results = {r["id"]: r["verdict"] for r in data["results"]}
    assert results == {c.id: "pass" for c in CASES}
    assert all(r["section"] == "16" for r in data["results"])
    assert "<testsuite" in junit.read_text() and "WM-009" in junit.read_text()
    assert "WM-001" in done.output  # the console reporter


def test_a_missing_module_fails_with_the_engine_verdicts(tmp_path: Path) -> None:
    thread = _serve()
    try:
        report = tmp_path / "wm.json"
        args = ["conform-worldmodel", f"127.0.0.1:{thread.port}", "--module", "Nobody"]
        args += ["--bound", "0.3", "--case", "WM-00", "--json", str(report)]
        done = CliRunner().invoke(main, args)
        none = CliRunner().invoke(main, [*args[:4], "--case", "WM-999"])
        lenient = CliRunner().invoke(main, [*args, "--fail-on", "none"])
    finally:
        thread.stop()
    assert done.exit_code == 1, done.output
    verdicts = {r["verdict"] for r in json.loads(report.read_text())["results"]}
    assert verdicts == {"fail"}
    assert none.exit_code == 2  # no case selected: a usage error, as in `openair conform`
    assert lenient.exit_code == 0, lenient.output


def test_an_unreachable_server_is_exit_3() -> None:
    done = CliRunner().invoke(main, ["conform-worldmodel", "127.0.0.1:1", "--module", "M"])
    assert done.exit_code == 3
