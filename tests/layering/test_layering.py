"""Layering of the kit's packages (issue #17): no import circle between top-level packages or
between the applications beside the core and the server, and the reference implementation
never imports the conformance suite that judges it (it finds the suite's commands through the
entry point group `openair.commands`)."""

from __future__ import annotations

import ast
import tomllib
from importlib.metadata import entry_points
from pathlib import Path

from layering_imports import ROOT, Import, all_imports, cycles, imports_of, python_files

#: The applications beside the protocol core and the server (they attach to the server through
#: `openair.observing`; the server never imports them).
APPLICATIONS = ("openair_monitor", "openair_ontology", "openair_worldmodel", "openair_recording")
SERVER = "openair.server"
KIT = ("openair", *APPLICATIONS, "openair_conformance")


def _package(name: str, depth: int) -> str | None:
    """The package of module `name` at `depth` (an application counts as one package)."""
    parts = name.split(".")
    if parts[0] in APPLICATIONS:
        return parts[0]
    return ".".join(parts[:depth]) if parts[0] in KIT else None


def _graph(imports: list[Import], depth: int) -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {}
    for item in imports:
        a, b = _package(item.module, depth), _package(item.target, depth)
        if a and b and a != b:
            edges.setdefault(a, set()).add(b)
    return edges


def _where(imports: list[Import], a: str, b: str, depth: int) -> list[str]:
    return [
        f"{i.path.relative_to(ROOT)}:{i.line} {i.module} -> {i.target}"
        for i in imports
        if _package(i.module, depth) == a and _package(i.target, depth) == b
    ]


def test_no_import_circle_between_top_level_packages() -> None:
    imports = all_imports()
    found = cycles(_graph(imports, 1))
    assert not found, found


def test_no_import_circle_between_the_applications_and_the_server() -> None:
    imports = all_imports()
    graph = _graph([i for i in imports if _package(i.module, 1) != "openair_conformance"], 2)
    for component in cycles(graph):
        involved = [name for name in component if name in (*APPLICATIONS, SERVER)]
        apps = [name for name in involved if name in APPLICATIONS]
        evidence = [
            line
            for a in component
            for b in component
            if a != b
            for line in _where(imports, a, b, 2)
        ]
        assert not apps, f"import circle {component}:\n" + "\n".join(evidence)


def test_the_reference_package_never_imports_the_conformance_suite() -> None:
    root = ROOT / "reference"
    offending = [
        f"{i.path.relative_to(ROOT)}:{i.line} imports {i.target}"
        for path in python_files(root / "openair")
        for i in imports_of(path, root)
        if _package(i.target, 1) == "openair_conformance"
    ]
    offending += _named_in_strings(root / "openair")
    assert not offending, "\n".join(offending)


def _named_in_strings(package: Path) -> list[str]:
    """String constants naming a conformance module ("openair_conformance.cli:conform"): a
    table of commands to import is an import too."""
    found = []
    for path in python_files(package):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                text = node.value.strip()
                if text.startswith(("openair_conformance.", "openair_conformance:")):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} names {text!r}")
    return found


def test_the_entry_points_installed_are_those_pyproject_declares() -> None:
    """The `openair` CLI lists conform* and the server attaches the monitor only through the
    entry points: an environment installed before they were declared must be reinstalled."""
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert set(declared) >= {"openair.commands", "openair.server.attachments"}
    for group, wanted in declared.items():
        installed = {ep.name: ep.value for ep in entry_points(group=group)}
        assert installed == wanted, f"{group}: reinstall (pip install -e .): {installed}"
    assert {"conform", "conform-client", "conform-worldmodel"} <= set(declared["openair.commands"])


# -- the checks themselves can fail ---------------------------------------------------------


def test_cycles_finds_circles_and_only_circles() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"a"}}) == [["a"]]
    assert cycles({"x": {"y"}, "y": {"x"}, "p": {"q"}, "q": {"p"}}) == [["p", "q"], ["x", "y"]]


def test_imports_are_read_wherever_they_run(tmp_path: Path) -> None:
    package = tmp_path / "pkg" / "sub"
    package.mkdir(parents=True)
    (tmp_path / "pkg" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    module = package / "mod.py"
    module.write_text(
        "from __future__ import annotations\n"
        "import importlib\n"
        "from typing import TYPE_CHECKING\n"
        "from . import sibling\n"
        "from ..other import thing\n"
        "if TYPE_CHECKING:\n"
        "    from openair.server.aio.app import Server\n"
        "def later():\n"
        "    import openair_conformance.cli\n"
        "    table = {'x': 'openair_recording.cli_recording:record'}\n"
        "    return importlib.import_module('openair_monitor')\n"
    )
    targets = {i.target for i in imports_of(module, tmp_path)}
    assert {"pkg.sub.sibling", "pkg.other", "pkg.other.thing"} <= targets
    assert {"openair_conformance.cli", "openair_monitor"} <= targets
    assert "openair_recording.cli_recording" in targets  # named in a "module:attribute" table
    assert "openair.server.aio.app" not in targets  # TYPE_CHECKING imports never run


#: Line limit of a hand-written module (issue #17); generated modules say so in their first lines.
MAX_LINES = 600
GENERATED_MARK = "do not edit"


def test_no_hand_written_module_is_over_600_lines() -> None:
    """Small modules (house style): every hand-written Python module of the kit <= 600 lines."""
    long = []
    for package in ("reference/openair", "apps", "conformance/openair_conformance"):
        for path in python_files(ROOT / package):
            text = path.read_text(encoding="utf-8")
            if GENERATED_MARK in text[:400].lower():
                continue
            lines = text.count("\n")
            if lines > MAX_LINES:
                long.append(f"{path.relative_to(ROOT)}: {lines} lines")
    assert not long, "\n".join(long)
