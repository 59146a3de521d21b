"""The sans-I/O parts of the kit stay sans-I/O, and the protocol core sits below the roles
(issue #17): nothing under `openair/protocol` or `openair/server/core` imports asyncio, socket,
threading, selectors, ssl, subprocess or `time`, or reads the clock; `openair.protocol` imports
nothing of the server, the client, the applications or the conformance suite, and the server
core nothing of its asyncio adapter."""

from __future__ import annotations

from pathlib import Path

import pytest
from layering_imports import ROOT, imports_of, python_files
from sans_io_check import io_problems

REFERENCE = ROOT / "reference"
SANS_IO = (REFERENCE / "openair" / "protocol", REFERENCE / "openair" / "server" / "core")

#: What `openair.protocol` may import from the kit: itself, and the paths of the shipped data.
PROTOCOL_MAY_IMPORT = ("openair.protocol", "openair.resources")
#: What the server core may not import: its adapter, the CLI layer, the other roles, the
#: applications (`openair.monitor` … in the package, `openair_monitor` … under apps/) and the
#: conformance suite.
CORE_MAY_NOT_IMPORT = (
    "openair.server.aio",
    "openair.server.cli_serve",
    "openair.server.cli_budgets",
    "openair.client",
    "openair.cluster",
    "openair.monitor",
    "openair.ontology",
    "openair.worldmodel",
    "openair.recording",
    "openair.cli",
)


def _within(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _of_the_kit(name: str) -> bool:
    """`openair.…`, an application (`openair_monitor`, …) or the suite (`openair_conformance`)."""
    return name.startswith(("openair.", "openair_"))


def role_problems(package: Path, root: Path) -> list[str]:
    """Imports that put the protocol core (`package`) above a role or an application."""
    return [
        f"{i.path}:{i.line} imports {i.target}"
        for path in python_files(package)
        for i in imports_of(path, root)
        if _of_the_kit(i.target) and not _within(i.target, PROTOCOL_MAY_IMPORT)
    ]


def adapter_problems(package: Path, root: Path) -> list[str]:
    """Imports of the server core (`package`) of its adapter, a role, an app or the suite."""
    return [
        f"{i.path}:{i.line} imports {i.target}"
        for path in python_files(package)
        for i in imports_of(path, root)
        if _within(i.target, CORE_MAY_NOT_IMPORT) or i.target.startswith("openair_")
    ]


@pytest.mark.parametrize("package", SANS_IO, ids=lambda p: str(p.relative_to(REFERENCE)))
def test_no_io_and_no_clock_in_the_sans_io_packages(package: Path) -> None:
    modules = list(python_files(package))
    assert len(modules) > 5, f"{package} holds no modules: the layout moved"
    problems = [p for path in modules for p in io_problems(path, REFERENCE)]
    assert not problems, "\n".join(problems)


def test_the_protocol_core_imports_no_role() -> None:
    problems = role_problems(REFERENCE / "openair" / "protocol", REFERENCE)
    assert not problems, "\n".join(problems)


def test_the_server_core_imports_no_adapter_and_no_application() -> None:
    problems = adapter_problems(REFERENCE / "openair" / "server" / "core", REFERENCE)
    assert not problems, "\n".join(problems)


# -- the checks themselves can fail ---------------------------------------------------------


def _module(tmp_path: Path, source: str) -> Path:
    package = tmp_path / "openair" / "protocol"
    package.mkdir(parents=True, exist_ok=True)
    (tmp_path / "openair" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    path = package / "mod.py"
    path.write_text(source)
    return path


@pytest.mark.parametrize(
    ("source", "reported"),
    [
        ("import asyncio\n", "imports asyncio"),
        ("import socket as s\n", "imports socket"),
        ("from threading import Thread\n", "imports threading"),
        ("def f():\n    import selectors\n", "imports selectors"),  # lazy: still runs
        ("def f():\n    from ssl import create_default_context\n", "imports ssl"),
        ("import subprocess\n", "imports subprocess"),
        ("def f():\n    import sqlite3\n", "imports sqlite3"),
        ("from concurrent.futures import ThreadPoolExecutor\n", "imports concurrent.futures"),
        ("import time\nNOW = time.time()\n", "imports time"),
        ("from time import monotonic\n", "imports time"),
        ("from time import perf_counter as pc\n", "imports time"),
        ("from datetime import datetime\nx = datetime.now()\n", "datetime.now()"),
        ("import datetime\nx = datetime.datetime.now(datetime.UTC)\n", "datetime.now()"),
        ("from datetime import date\nx = date.today()\n", "date.today()"),
        ("def f(loop):\n    return loop.time()\n", "loop.time()"),
        ("def f(a):\n    return a.get_running_loop().time()\n", "get_running_loop().time()"),
    ],
)
def test_the_check_fails_on_io_or_a_clock_read(tmp_path: Path, source: str, reported: str) -> None:
    problems = io_problems(_module(tmp_path, source), tmp_path)
    assert problems, source
    assert any(reported in p for p in problems), problems


def test_the_check_passes_time_passed_in_and_type_only_imports(tmp_path: Path) -> None:
    source = (
        "from __future__ import annotations\n"
        "from typing import TYPE_CHECKING\n"
        "from datetime import UTC, datetime\n"
        "if TYPE_CHECKING:\n"
        "    import asyncio\n"
        "def stamp(now_ns: int) -> str:\n"
        "    return datetime.fromtimestamp(now_ns / 1e9, tz=UTC).isoformat()\n"
        "def later(msg: Message) -> int:\n"
        "    return msg.time  # an attribute, not a clock\n"
    )
    assert io_problems(_module(tmp_path, source), tmp_path) == []


@pytest.mark.parametrize(
    "source",
    [
        "from openair.server.core.router import Router\n",
        "def f():\n    import openair.client.module\n",
        "from openair import observing\n",
        "import openair_monitor\n",
        "import openair_conformance.cli\n",
    ],
)
def test_the_role_check_fails_on_a_protocol_module_importing_above_it(
    tmp_path: Path, source: str
) -> None:
    _module(tmp_path, source)
    assert role_problems(tmp_path / "openair" / "protocol", tmp_path)


def test_the_role_check_passes_protocol_and_data_imports(tmp_path: Path) -> None:
    _module(tmp_path, "from openair.protocol.message import Message\nimport openair.resources\n")
    assert role_problems(tmp_path / "openair" / "protocol", tmp_path) == []


@pytest.mark.parametrize(
    "source",
    [
        "from openair.server.aio.app import Server\n",
        "def f():\n    from openair.cluster import open_cluster_store\n",
        "import openair_ontology\n",
    ],
)
def test_the_adapter_check_fails_on_a_core_module_importing_outward(
    tmp_path: Path, source: str
) -> None:
    _module(tmp_path, source)
    assert adapter_problems(tmp_path / "openair" / "protocol", tmp_path)
