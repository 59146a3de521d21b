"""The `openair conform` group through click's CliRunner (servers run in background threads)."""

from __future__ import annotations

import importlib.util
import socket
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result

from openair.catalogue import load_catalogue
from openair_conformance.cli import conform, parse_fail_on
from openair_conformance.model import Verdict
from openair_conformance.registry import all_cases


def _invoke(*args: str) -> Result:
    return CliRunner().invoke(conform, list(args), catch_exceptions=False)


def _installed(reporter: str) -> bool:
    try:
        return importlib.util.find_spec(f"openair_conformance.reporters.{reporter}") is not None
    except ModuleNotFoundError:
        return False


def _address(target: tuple[str, int]) -> str:
    return f"{target[0]}:{target[1]}"


def test_help_documents_the_exit_codes() -> None:
    for args in (["--help"], ["-h"], ["run", "--help"]):
        result = _invoke(*args)
        assert result.exit_code == 0
        assert "Exit codes:" in result.output and "3  cannot connect" in result.output


def test_list_shows_every_case() -> None:
    result = _invoke("list")
    assert result.exit_code == 0
    lines = result.output.splitlines()
    assert sorted(line.split()[0] for line in lines) == [c.info.id for c in all_cases()]
    sections = [tuple(int(p) for p in line.split()[2].split(".")) for line in lines]
    assert sections == sorted(sections)  # grouped by spec section
    assert any("needs pipelining" in line for line in lines)


def test_list_filters() -> None:
    result = _invoke("list", "--section", "6.4")
    listed = sorted(line.split()[0] for line in result.output.splitlines())
    expected = sorted(
        c.info.id
        for c in all_cases()
        if c.info.section == "6.4" or c.info.section.startswith("6.4.")
    )
    assert {"SESS-004", "SESS-005"} <= set(listed)
    assert listed == expected


def test_explain_quotes_the_requirements() -> None:
    result = _invoke("explain", "SESS-001", "--expectations", "psyclone-1.1.7")
    assert result.exit_code == 0, result.output
    catalogue = load_catalogue()
    assert " ".join(catalogue["OA-SESS-10"].text.split()) in " ".join(result.output.split())
    assert "What it does:" in result.output and "Allowed behaviours:" in result.output
    assert "Psyclone 1.1.7: no expectation for SESS-001" in result.output
    assert "openair conform HOST:PORT --case SESS-001" in result.output


def test_explain_shows_an_expectation() -> None:
    result = _invoke("explain", "CC-002", "--expectations", "psyclone-1.1.7")
    assert "expected fail — DEV-12" in result.output


def test_explain_unknown_case_is_a_usage_error() -> None:
    result = CliRunner().invoke(conform, ["explain", "SESS-01"])
    assert result.exit_code == 2
    assert "did you mean" in result.output


def test_coverage_lists_every_must_and_should() -> None:
    result = _invoke("coverage")
    assert result.exit_code == 0
    catalogue = load_catalogue()
    rows = {line.split()[0]: line for line in result.output.splitlines() if line.startswith("OA-")}
    wanted = {r.id for r in catalogue.values() if r.level in ("MUST", "SHOULD")}
    assert set(rows) == wanted
    assert "SESS-001" in rows["OA-SESS-10"] and "not testable over TCP" in rows["OA-GEN-1"]
    assert "MUST:" in result.output and "SHOULD:" in result.output
    missing = _invoke("coverage", "--missing").output
    assert "OA-SESS-10 " not in missing and "OA-GEN-1 " in missing
    assert "OA-MSG-7 " in _invoke("coverage", "--all").output  # a MAY


def test_run_against_the_target_passes(target: tuple[str, int]) -> None:
    result = _invoke(_address(target), "--case", "SESS-00[1-3]", "-j", "2")
    assert result.exit_code == 0, result.output


def test_explicit_run_subcommand(target: tuple[str, int]) -> None:
    assert _invoke("run", _address(target), "--case", "SESS-001").exit_code == 0


def test_fail_on_decides_the_exit_code(fake_server_with: Any) -> None:
    address = _address(fake_server_with(faults=frozenset({"ping_isresponse"})))
    assert _invoke(address, "--case", "SESS-001").exit_code == 1
    assert _invoke(address, "--case", "SESS-001", "--fail-on", "none").exit_code == 0
    assert _invoke(address, "--case", "SESS-001", "--fail-on", "timing").exit_code == 0


def test_unreachable_target_exits_3() -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    result = CliRunner().invoke(conform, [f"127.0.0.1:{port}"])
    assert result.exit_code == 3
    assert "cannot talk to" in result.output


@pytest.mark.parametrize(
    "args",
    [
        ["127.0.0.1:notaport"],
        ["127.0.0.1:1", "--fail-on", "fial"],
        ["127.0.0.1:1", "--jobs", "0"],
        ["127.0.0.1:1", "--timeout-scale", "0"],
        ["127.0.0.1:1", "--expectations", "no-such-file.xml"],
    ],
)
def test_usage_errors_exit_2(args: list[str]) -> None:
    assert CliRunner().invoke(conform, args).exit_code == 2


def test_no_case_selected_exits_2(target: tuple[str, int]) -> None:
    result = CliRunner().invoke(conform, [_address(target), "--case", "NOPE-*"])
    assert result.exit_code == 2 and "no case matches" in result.output


def test_parse_fail_on() -> None:
    assert parse_fail_on("fail, timing") == frozenset({Verdict.FAIL, Verdict.TIMING})
    assert parse_fail_on("none") == frozenset()


def test_missing_reporters_are_announced(target: tuple[str, int], tmp_path: Path) -> None:
    junit = tmp_path / "out.xml"
    result = _invoke(_address(target), "--case", "SESS-001", "--junit", str(junit))
    assert result.exit_code == 0
    if not _installed("junit"):
        assert "openair_conformance.reporters.junit is not installed" in result.output
    if not _installed("console"):
        assert "pass 1" in result.output  # the built-in summary stands in for the console
    else:
        assert junit.exists()


def test_report_refuses_a_file_that_is_not_a_report(tmp_path: Path) -> None:
    report = tmp_path / "a.json"
    report.write_text("{}")
    result = CliRunner().invoke(conform, ["report", str(report), "-o", str(tmp_path / "o.html")])
    assert result.exit_code == 2, result.output  # a usage error, not a traceback
    assert not (tmp_path / "o.html").exists()
