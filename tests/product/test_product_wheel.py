"""The kit as users install it: a wheel in a clean virtual environment, without test extras.

Issue #18: the wheel crashed on first use (`openair --version` imported xmlschema, `openair
conform` hypothesis). The wheel is built once per test session (`pip wheel --no-deps`) and
installed with its runtime dependencies only (from the package index); then every command a
user starts with runs from that environment, against a server started from it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from importlib.metadata import version
from pathlib import Path

import pytest
from product_support import ServeProcess, openair_command

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
_RUN_S = 300  # bound on one command (the conformance suite takes ~10 s)


@pytest.fixture(scope="session")
def built_wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Build the wheel once."""
    base = tmp_path_factory.mktemp("wheel")
    source = _source_copy(base / "src")
    _check([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(base), str(source)])
    wheels = sorted(base.glob("openair_kit-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def _venv_with(base: Path, requirement: str) -> Path:
    venv = base / "venv"
    _check([sys.executable, "-m", "venv", str(venv)])
    python = venv / "bin" / "python"
    _check([str(python), "-m", "pip", "install", "-q", requirement])
    return python


@pytest.fixture(scope="session")
def clean_python(built_wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Install the wheel into a fresh venv (its base dependencies only); return its python."""
    return _venv_with(tmp_path_factory.mktemp("base"), str(built_wheel))


@pytest.fixture(scope="session")
def apps_python(built_wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel with the applications' extras (issue #17: `[monitor,ontology]`)."""
    return _venv_with(tmp_path_factory.mktemp("apps"), f"{built_wheel}[monitor,ontology]")


def _source_copy(into: Path) -> Path:
    """Copy what the wheel is built from (not a stale build/ folder of the working tree)."""
    into.mkdir()
    for name in ("pyproject.toml", "README.md", "setup.py"):  # setup.py: the C data path
        shutil.copy2(ROOT / name, into / name)
    skip = shutil.ignore_patterns("__pycache__", "*.egg-info", "build", "*.so")
    # _data/ links to the last two
    for name in ("reference", "apps", "conformance", "schemas", "spec"):
        shutil.copytree(ROOT / name, into / name, symlinks=True, ignore=skip)
    return into


def _check(cmd: list[str]) -> None:
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=_RUN_S, check=False)
    assert done.returncode == 0, f"{cmd}: {done.stdout}{done.stderr}"


def _openair(python: Path, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*openair_command(python), *args],
        capture_output=True,
        text=True,
        timeout=_RUN_S,
        check=False,
        cwd=cwd,
    )


def _no_traceback(done: subprocess.CompletedProcess[str]) -> None:
    assert "Traceback" not in done.stdout + done.stderr, done.stderr


def test_the_clean_venv_has_no_test_extras(clean_python: Path) -> None:
    for optional in ("hypothesis", "xmlschema", "selenium", "pytest", "h11", "graphviz"):
        done = subprocess.run([str(clean_python), "-c", f"import {optional}"], check=False)
        assert done.returncode != 0, f"{optional} is installed: the venv is not clean"


def test_version_and_help(clean_python: Path) -> None:
    done = _openair(clean_python, "--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith(version("openair-kit"))
    listing = _openair(clean_python, "--help")
    assert listing.returncode == 0, listing.stderr
    for command in ("serve", "post", "watch", "conform", "ontology", "stream"):
        assert f"  {command} " in listing.stdout


def test_serve_conform_stream_ls_and_stop(clean_python: Path) -> None:
    server = ServeProcess(python=clean_python)
    try:
        target = f"127.0.0.1:{server.port}"
        run = _openair(clean_python, "conform", target, "-j", "2")
        _no_traceback(run)
        assert run.returncode == 0, run.stdout[-2000:] + run.stderr
        assert "pip install 'openair-kit[fuzz]'" in run.stderr  # FUZZ-001 needs the extra
        listed = _openair(clean_python, "stream", "ls", "--server", target)
        assert listed.returncode == 0, listed.stderr
        assert "Stream1" in listed.stdout
        assert server.stop() == 0, server.stderr()
    finally:
        server.kill()


def test_ontology_docs(apps_python: Path, tmp_path: Path) -> None:
    site = tmp_path / "site"
    ontology = ROOT / "examples" / "seed-paper.ontology.xml"
    done = _openair(apps_python, "ontology", "docs", str(ontology), "-o", str(site))
    _no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert (site / "index.html").is_file()


@pytest.mark.parametrize(
    ("args", "extra"),
    [
        (("conform-worldmodel", "127.0.0.1:1", "--module", "M"), "worldmodel"),
        (("conform", "127.0.0.1:1", "--case", "FUZZ-001"), "fuzz"),
        (("ontology", "docs", "x.ontology.xml", "-o", "site"), "ontology"),  # issue #17
        (("monitor", "x.rec"), "monitor"),
    ],
)
def test_a_missing_extra_is_one_line(clean_python: Path, args: tuple[str, ...], extra: str) -> None:
    done = _openair(clean_python, *args)
    _no_traceback(done)
    assert done.returncode == 2
    assert f"pip install 'openair-kit[{extra}]'" in done.stderr


def test_the_wheel_builds_without_a_compiler(tmp_path: Path) -> None:
    """Issue #20: no compiler (CC=/bin/false) still gives a wheel, with the pure data path."""
    source = _source_copy(tmp_path / "src")
    env = {**os.environ, "CC": "/bin/false"}
    cmd = [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path)]
    cmd.append(str(source))
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=_RUN_S, env=env, check=False)
    assert done.returncode == 0, done.stderr
    (wheel,) = tmp_path.glob("openair_kit-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "openair/server/aio/datapath/pure.py" in names
    assert not [n for n in names if "_native" in n and not n.endswith(".c")], names
    venv = tmp_path / "venv"
    _check([sys.executable, "-m", "venv", str(venv)])
    python = venv / "bin" / "python"
    _check([str(python), "-m", "pip", "install", "-q", str(wheel)])
    probe = "from openair.server.aio.datapath import select; print(select({}).name)"
    done = subprocess.run([str(python), "-c", probe], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "python"


def test_the_wheel_holds_the_native_data_path(clean_python: Path) -> None:
    """With a compiler (this machine has one), the installed wheel picks the native path."""
    probe = "from openair.server.aio.datapath import select; print(select({}).name)"
    done = subprocess.run(
        [str(clean_python), "-c", probe], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "native"
