"""`openair serve` as users start it (issue #18): one-line errors for every store and
configuration failure (exit 2, no traceback), and the psySpec's `<global><port>` (OA-CONF-7)."""

from __future__ import annotations

import sqlite3
import subprocess
from pathlib import Path

import pytest
from product_support import ServeProcess, free_port, openair_command

ROOT = Path(__file__).resolve().parents[2]
_PSYSPEC = """<psySpec name="PortTest" version="1.2">
  <global>
    <title>port test</title>
    <port>{port}</port>
  </global>
  <whiteboard name="AIRCentral"/>
  <whiteboard name="PortWB"/>
</psySpec>
"""


def _serve(*args: str) -> subprocess.CompletedProcess[str]:
    """Start `openair serve ARGS`, which must fail before it listens."""
    return subprocess.run(
        [*openair_command(), "serve", "--host", "127.0.0.1", "--port", "0", *args],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def _one_line_error(done: subprocess.CompletedProcess[str], *words: str) -> None:
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("openair serve:")]
    assert len(errors) == 1, done.stderr
    for word in words:
        assert word in errors[0]


def test_a_store_in_a_missing_directory(tmp_path: Path) -> None:
    path = tmp_path / "nonexistent" / "dir" / "wb.db"
    _one_line_error(_serve("--store", f"sqlite:{path}"), str(path), "no directory")


def test_a_store_that_is_a_directory(tmp_path: Path) -> None:
    _one_line_error(_serve("--store", f"sqlite:{tmp_path}"), "is a directory")


def test_a_store_that_is_not_a_database(tmp_path: Path) -> None:
    path = tmp_path / "notes.txt"
    path.write_bytes(b"these are notes, not a database\n" * 200)
    _one_line_error(_serve("--store", f"sqlite:{path}"), "not a database")


def test_a_database_of_another_shape(tmp_path: Path) -> None:
    path = tmp_path / "other.db"
    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE messages (id INTEGER PRIMARY KEY, text TEXT)")
    _one_line_error(_serve("--store", f"sqlite:{path}"), "cannot open the store")


@pytest.mark.parametrize("spec", ["bogus", "sqlite:", "postgres:db"])
def test_an_unknown_store(spec: str) -> None:
    _one_line_error(_serve("--store", spec), "unknown store")


def test_configuration_failures(tmp_path: Path) -> None:
    _one_line_error(_serve("--config", str(tmp_path / "missing.xml")), "missing.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text("<psySpec><global>", encoding="utf-8")
    _one_line_error(_serve("--config", str(broken)), "broken.xml")
    done = _serve("--config", str(tmp_path))  # refused by click as a usage error
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "is a directory" in done.stderr


def _psyspec(tmp_path: Path, port: int) -> Path:
    path = tmp_path / "psySpec.xml"
    path.write_text(_PSYSPEC.format(port=port), encoding="utf-8")
    return path


def test_the_psyspec_port_is_the_main_port(tmp_path: Path) -> None:
    port = free_port()
    server = ServeProcess("--config", str(_psyspec(tmp_path, port)), port0=False)
    try:
        assert server.port == port  # OA-CONF-7
        assert server.stop() == 0
    finally:
        server.kill()


def test_the_command_line_port_wins(tmp_path: Path) -> None:
    configured, given = free_port(), free_port()
    config = str(_psyspec(tmp_path, configured))
    server = ServeProcess("--config", config, "--port", str(given), port0=False)
    try:
        assert server.port == given  # OA-CONF-7: a port given another way wins
        assert server.stop() == 0
    finally:
        server.kill()


def test_a_psyspec_port_out_of_range(tmp_path: Path) -> None:
    done = subprocess.run(
        [*openair_command(), "serve", "--config", str(_psyspec(tmp_path, 70000))],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    _one_line_error(done, "70000")
