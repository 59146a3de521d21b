"""The applications beside the core (apps/, issue #17) stay beside it.

- The core (`openair`) imports no application: the `openair` CLI finds their commands and the
  server its attachments through entry points (pyproject.toml).
- An application imports only the public interface of the core (`PUBLIC_CORE`): the role-neutral
  protocol, the client, the observer interface the server exports, the shipped data paths. It
  never imports the server (`openair.server`), a private module or a private name.
- No import circle among the applications and the core.
- What the reference server gives its applications (`ObservedView`) is an
  `openair.observing.ObservedServer` (checked by mypy: a view that stops offering a member the
  interface names fails here).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from layering_imports import ROOT, Import, cycles, imports_of, python_files

APPS = ROOT / "apps"
APPLICATIONS = ("openair_monitor", "openair_ontology", "openair_recording", "openair_worldmodel")

#: What an application may import from the core: these modules and what is under them.
PUBLIC_CORE = (
    "openair.protocol",  # the role-neutral protocol core (spec, codec, psySpec, ...)
    "openair.client",  # the client API and its command-line helpers
    "openair.observing",  # the observer interface the server exports
    "openair.resources",  # paths of the shipped schemas and spec tables
    "openair.extras",  # which extra installs a missing package
)
#: `import openair` (the version) is public too.
PUBLIC_ROOT = "openair"


def app_imports(root: Path = APPS) -> list[Import]:
    return [
        i
        for package in sorted(p for p in root.iterdir() if (p / "__init__.py").is_file())
        for path in python_files(package)
        for i in imports_of(path, root)
    ]


def core_problems(imports: list[Import]) -> list[str]:
    """Imports of the core that are not its public interface."""
    problems = []
    for i in imports:
        parts = i.target.split(".")
        if parts[0] != "openair" or i.target == PUBLIC_ROOT:
            continue
        public = any(i.target == p or i.target.startswith(p + ".") for p in PUBLIC_CORE)
        private = any(part.startswith("_") for part in parts[1:])
        if not public or private:
            problems.append(f"{i.path}:{i.line} {i.module} imports {i.target}")
    return problems


def test_apps_are_the_applications() -> None:
    found = sorted(p.name for p in APPS.iterdir() if (p / "__init__.py").is_file())
    assert found == sorted(APPLICATIONS)


def test_the_core_imports_no_application() -> None:
    root = ROOT / "reference"
    offending = [
        f"{i.path.relative_to(ROOT)}:{i.line} imports {i.target}"
        for path in python_files(root / "openair")
        for i in imports_of(path, root)
        if i.target.split(".")[0] in APPLICATIONS
    ]
    assert not offending, "\n".join(offending)


def test_the_applications_import_only_the_public_core() -> None:
    problems = core_problems(app_imports())
    assert not problems, "\n".join(problems)


def test_no_circle_among_the_applications_and_the_core() -> None:
    edges: dict[str, set[str]] = {}
    core = ROOT / "reference"
    everything = app_imports() + [
        i for path in python_files(core / "openair") for i in imports_of(path, core)
    ]
    for i in everything:
        a, b = i.module.split(".")[0], i.target.split(".")[0]
        if a != b and {a, b} <= {"openair", *APPLICATIONS}:
            edges.setdefault(a, set()).add(b)
    assert not cycles(edges), cycles(edges)


_CONFORMS = """
from openair.observing import ObservedServer
from openair.server.aio.app import Server
from openair.server.aio.observed import ObservedView

def attach(server: Server) -> ObservedServer:
    return ObservedView(server)
"""

_LACKS = """
from openair.observing import ObservedServer

class Partial:
    host = "127.0.0.1"

def attach(server: Partial) -> ObservedServer:
    return server
"""


def _mypy(program: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    """mypy --strict on `program`, with the source roots on its path (not the project's files)."""
    config = tmp_path / "mypy.ini"
    # Errors inside the imported modules are `make typecheck`'s to report; this is about `program`.
    config.write_text(
        "[mypy]\nstrict = True\nfollow_imports = silent\n"
        f"cache_dir = {tmp_path / 'cache'}\n"
        "[mypy-xmlschema.*]\nignore_missing_imports = True\n"
    )
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(config), "-c", program],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
        cwd=ROOT,
        env={**os.environ, "MYPYPATH": f"{ROOT / 'reference'}:{ROOT / 'apps'}"},
    )


@pytest.mark.slow
def test_the_server_gives_an_observed_server(tmp_path: Path) -> None:
    done = _mypy(_CONFORMS, tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.mark.slow
def test_the_observed_server_check_can_fail(tmp_path: Path) -> None:
    done = _mypy(_LACKS, tmp_path)
    assert done.returncode == 1 and "ObservedServer" in done.stdout, done.stdout + done.stderr


# -- the checks themselves can fail ---------------------------------------------------------


def _app(tmp_path: Path, source: str) -> Path:
    package = tmp_path / "openair_demo"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "mod.py").write_text(source)
    return tmp_path


@pytest.mark.parametrize(
    "source",
    [
        "from openair.server.aio.app import Server\n",
        "import openair.server.core.router\n",
        "from openair.client.cli_client import _run\n",
        "from openair.protocol._errors_base import Base\n",
        "from openair.cli import main\n",
        "import importlib\ndef later():\n    return importlib.import_module('openair.cluster')\n",
    ],
)
def test_the_public_core_check_fails_on(tmp_path: Path, source: str) -> None:
    assert core_problems(app_imports(_app(tmp_path, source)))


def test_the_public_core_check_passes(tmp_path: Path) -> None:
    source = (
        "import openair\n"
        "from openair.protocol.message import Message\n"
        "from openair.client import Module\n"
        "from openair.observing import ObservedServer\n"
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from openair.server.aio.app import Server\n"
    )
    assert core_problems(app_imports(_app(tmp_path, source))) == []
