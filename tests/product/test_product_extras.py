"""The core installs light; the applications beside it bring their dependencies as extras (#17).

`pip install openair-kit` gives the protocol core, the server, the client and the conformance
suite (pyproject `dependencies`); the web monitor (`[monitor]`: h11), the ontology tools
(`[ontology]`: graphviz, jinja2) and the world model (`[worldmodel]`) are extras. These tests
read pyproject.toml and import the core in a child interpreter that refuses the extras'
packages, as a machine without them would.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]

#: What the base install holds, and which part needs it.
BASE = {
    "lxml": "the protocol core (hardened XML)",
    "click": "the `openair` command line",
    "jinja2": "the conformance suite's HTML report",
    "jsonschema": "the conformance suite's JSON report and `conform-client` shim lines",
}
#: The applications' extras and the packages each must bring.
APP_EXTRAS = {"monitor": {"h11"}, "ontology": {"graphviz", "jinja2"}, "worldmodel": {"xmlschema"}}
#: What the core must import without (the applications' and the optional parts' packages).
HIDDEN = ("h11", "graphviz", "jinja2", "jsonschema", "xmlschema", "hypothesis", "selenium", "nats")


def _name(requirement: str) -> str:
    found = re.match(r"[A-Za-z0-9_.-]+", requirement)
    assert found, requirement
    return found.group(0).lower().replace("_", "-")


def test_the_base_install_is_the_core_and_the_suite() -> None:
    assert {_name(r) for r in PYPROJECT["dependencies"]} == set(BASE)


def test_each_application_names_its_extra() -> None:
    extras = PYPROJECT["optional-dependencies"]
    for extra, wanted in APP_EXTRAS.items():
        assert {_name(r) for r in extras[extra]} >= wanted, extra
    test = " ".join(extras["test"])
    for extra in APP_EXTRAS:
        assert re.search(rf"openair-kit\[[^\]]*\b{extra}\b", test), f"test lacks [{extra}]"


_REFUSE = """
import importlib.abc, sys
HIDDEN = {hidden!r}
class Refuse(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in HIDDEN:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None
sys.meta_path.insert(0, Refuse())
"""


def _run_without_extras(code: str, hidden: tuple[str, ...] = HIDDEN) -> str:
    script = _REFUSE.format(hidden=hidden) + textwrap.dedent(code)
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_the_refusing_finder_refuses() -> None:
    """The check below can fail: an import of a hidden package raises."""
    out = _run_without_extras(
        """
        try:
            import h11
        except ModuleNotFoundError as exc:
            print("refused", exc.name)
        """
    )
    assert out.split() == ["refused", "h11"]


CORE = (
    "openair",
    "openair.protocol",
    "openair.observing",
    "openair.client",
    "openair.server",
    "openair.server.aio.app",
    "openair.server.cli_serve",
    "openair.cli",
)


@pytest.mark.parametrize("module", CORE)
def test_the_core_imports_without_the_extras(module: str) -> None:
    out = _run_without_extras(
        f"""
        import importlib, sys
        importlib.import_module({module!r})
        print(sorted(m for m in sys.modules if m.partition(".")[0] in HIDDEN))
        """
    )
    assert out.strip() == "[]"


def test_a_server_starts_without_the_monitor_extra() -> None:
    """Without h11 the server serves, logs which extra the monitor needs, and does not claim
    the `monitor` extension it cannot serve (OA-EXT-1)."""
    out = _run_without_extras(
        """
        import asyncio, logging
        from openair.server.aio.app import ServerOptions, start_server
        logging.basicConfig(level=logging.WARNING, format="%(message)s")
        async def main():
            server = await start_server(ServerOptions(port=0))
            print("monitor" in server.extensions, server.monitor is None)
            await server.stop()
        asyncio.run(main())
        """,
        hidden=("h11",),
    )
    assert out.split() == ["False", "True"]


@pytest.mark.parametrize(
    ("command", "hidden", "extra"),
    [
        (("ontology", "lint", "x.xml"), "graphviz", "ontology"),
        (("monitor", "x.rec"), "h11", "monitor"),
    ],
)
def test_an_application_command_without_its_extra_names_it(
    command: tuple[str, ...], hidden: str, extra: str
) -> None:
    code = f"""
        import sys
        from openair.cli import main
        sys.argv = ["openair", *{command!r}]
        try:
            main()
        except SystemExit as exc:
            print("exit", exc.code)
        """
    script = _REFUSE.format(hidden=(hidden,)) + textwrap.dedent(code)
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=False
    )
    assert "exit 2" in done.stdout, done.stdout + done.stderr
    assert f"pip install 'openair-kit[{extra}]'" in done.stderr


def test_openair_serve_without_the_monitor_extra_names_it() -> None:
    """`openair serve` starts, and says on stderr which extra the web monitor needs."""
    code = """
        import sys
        from openair.cli import main
        sys.argv = ["openair", "serve", "--host", "127.0.0.1", "--port", "0"]
        main()
        """
    script = _REFUSE.format(hidden=("h11",)) + textwrap.dedent(code)
    with subprocess.Popen(
        [sys.executable, "-c", script],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as proc:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # blocks until the server is up (or exits: "")
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    assert line.startswith("listening on "), line + err
    assert "no web monitor: pip install 'openair-kit[monitor]'" in err
    assert "Traceback" not in err
