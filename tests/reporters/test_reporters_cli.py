"""`openair conform` as a user runs it: reports that cannot be written, new folders, cache files."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import lxml.html
import pytest
from click.testing import CliRunner, Result

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from server_thread import ReferenceServer

from openair_conformance.cli import conform

_OPENAIR = Path(sys.executable).with_name("openair")


@pytest.fixture(scope="module")
def address() -> Iterator[str]:
    """The reference server, for the module."""
    server = ReferenceServer()
    yield f"127.0.0.1:{server.port}"
    server.stop()


def _conform(*args: str) -> Result:
    return CliRunner().invoke(conform, list(args), catch_exceptions=False)


def test_a_report_that_cannot_be_written_exits_4(address: str, tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    json_path = tmp_path / "r.json"
    html = blocker / "r.html"  # a file is in the way of the folder
    result = _conform(address, "--case", "SESS-001", "--html", str(html), "--json", str(json_path))
    assert result.exit_code == 4, result.output
    assert f"error: could not write the HTML report to {html}" in result.output
    assert json_path.exists()  # the other reports are still written
    assert _conform(address, "--case", "SESS-001", "--json", str(json_path)).exit_code == 0


def test_a_missing_folder_is_created_and_said(address: str, tmp_path: Path) -> None:
    html = tmp_path / "new" / "sub" / "r.html"
    result = _conform(address, "--case", "SESS-001", "--html", str(html))
    assert result.exit_code == 0, result.output
    assert html.exists()
    assert f"note: created the folder {html.parent} for the HTML report" in result.output


def test_the_html_report_carries_traces_of_passes_only_when_asked(
    address: str, tmp_path: Path
) -> None:
    small, full = tmp_path / "small.html", tmp_path / "full.html"
    assert _conform(address, "--case", "SESS-001", "--html", str(small)).exit_code == 0
    args = ("--case", "SESS-001", "--html", str(full), "--html-traces", "all")
    assert _conform(address, *args).exit_code == 0
    brief = lxml.html.fromstring(small.read_bytes()).xpath("//article[@id='case-SESS-001']")[0]
    assert brief.xpath(".//ol[@class='trace']") == [] and brief.xpath(".//p[@class='omitted']")
    whole = lxml.html.fromstring(full.read_bytes()).xpath("//article[@id='case-SESS-001']")[0]
    assert whole.xpath(".//ol[@class='trace']/li")
    assert _conform(address, "--html-traces", "some").exit_code == 2


def test_conform_report_that_cannot_be_written_exits_4(address: str, tmp_path: Path) -> None:
    report = tmp_path / "r.json"
    assert _conform(address, "--case", "SESS-001", "--json", str(report)).exit_code == 0
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = _conform("report", str(report), "-o", str(blocker / "page.html"))
    assert result.exit_code == 4
    assert "error: could not write" in result.output


def test_help_documents_exit_code_4() -> None:
    assert "4  a report asked for" in _conform("run", "--help").output


@pytest.mark.skipif(not _OPENAIR.exists(), reason="the openair script is not installed")
def test_the_fuzz_case_leaves_no_hypothesis_folder_in_the_working_folder(
    address: str, tmp_path: Path
) -> None:
    pytest.importorskip("hypothesis")
    cwd, cache = tmp_path / "work", tmp_path / "cache"
    cwd.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("HYPOTHESIS")}
    env["XDG_CACHE_HOME"] = str(cache)
    args = [str(_OPENAIR), "conform", address, "--case", "FUZZ-001", "--fuzz-examples", "2"]
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert list(cwd.iterdir()) == []
    # Hypothesis writes its storage only when a run needs it (two random sequences may not), so
    # whatever it wrote is under the cache; that the run points it there is checked below.
    written = [p for p in cache.rglob("*") if p.is_file()] if cache.exists() else []
    assert all(cache / "openair" / "hypothesis" in p.parents for p in written), written


def test_the_suite_points_hypothesis_storage_into_the_user_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from openair_conformance.cli import _hypothesis_home

    monkeypatch.delenv("HYPOTHESIS_STORAGE_DIRECTORY", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    with _hypothesis_home():
        assert os.environ["HYPOTHESIS_STORAGE_DIRECTORY"] == str(
            tmp_path / "openair" / "hypothesis"
        )
    assert "HYPOTHESIS_STORAGE_DIRECTORY" not in os.environ  # only while the suite runs
    monkeypatch.setenv("HYPOTHESIS_STORAGE_DIRECTORY", "/elsewhere")
    with _hypothesis_home():
        assert os.environ["HYPOTHESIS_STORAGE_DIRECTORY"] == "/elsewhere"  # the user's wins


def test_conform_client_report_that_cannot_be_written_exits_4(tmp_path: Path) -> None:
    from openair_conformance.client_cli import conform_client

    blocker = tmp_path / "file"
    blocker.write_text("x")
    shim = f"{sys.executable} -m openair.client.shim"
    args = ["--shim", shim, "--scenario", "CLI-001", "--html-traces", "all"]
    runner = CliRunner()
    bad = runner.invoke(conform_client, [*args, "--json", str(blocker / "r.json")])
    assert bad.exit_code == 4, bad.output
    good = runner.invoke(conform_client, [*args, "--json", str(tmp_path / "r.json")])
    assert good.exit_code == 0, good.output
