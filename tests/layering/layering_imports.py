"""The import graph of the kit's Python packages, read from the source with `ast`.

Every `import x` and `from x import y` counts, wherever it stands (a function body too: a lazy
import is still a dependency), and so do `importlib.import_module("x")` with a literal name and
a "module:attribute" string (a table of things to import by name, as entry points are written);
imports under `if TYPE_CHECKING:` do not (they never run). Relative imports are resolved.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: Where the importable packages live (pyproject.toml, tool.setuptools.packages.find).
SOURCE_ROOTS = (ROOT / "reference", ROOT / "apps", ROOT / "conformance")


#: "package.module:attribute", an import by name.
_BY_NAME = re.compile(r"^([A-Za-z_][\w]*(?:\.[A-Za-z_]\w*)*):[A-Za-z_]\w*$")


@dataclass(frozen=True, slots=True)
class Import:
    """`module` imports `target` (at `path`:`line`)."""

    module: str
    target: str
    path: Path
    line: int


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def python_files(package_dir: Path) -> Iterator[Path]:
    for path in sorted(package_dir.rglob("*.py")):
        if "_data" not in path.parts and "__pycache__" not in path.parts:
            yield path


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _resolve(module: str, is_package: bool, level: int, name: str | None) -> str:
    if level == 0:
        return name or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (level - 1)] if level > 1 else base
    return ".".join([*base, *([name] if name else [])])


def _targets(tree: ast.AST, module: str, is_package: bool) -> Iterator[tuple[str, int]]:
    """Yield (imported module, line) for every import that runs."""
    stack: list[ast.AST] = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _is_type_checking(node):
            stack.extend(node.orelse)
            continue
        if isinstance(node, ast.Import):
            yield from ((alias.name, node.lineno) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(module, is_package, node.level, node.module)
            yield base, node.lineno
            # `from pkg import sub` may import the submodule pkg.sub
            yield from ((f"{base}.{alias.name}", node.lineno) for alias in node.names)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            named = _BY_NAME.match(node.value)
            if named:
                yield named.group(1), node.lineno
        elif isinstance(node, ast.Call) and _is_import_module(node):
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                yield arg.value, node.lineno
        stack.extend(ast.iter_child_nodes(node))


def _is_import_module(node: ast.Call) -> bool:
    func = node.func
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    return name in ("import_module", "__import__") and bool(node.args)


def imports_of(path: Path, root: Path) -> list[Import]:
    """Every import in the file at `path` (under the source root `root`)."""
    module = module_name(path, root)
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    return [
        Import(module=module, target=target, path=path, line=line)
        for target, line in _targets(tree, module, is_package)
    ]


def all_imports() -> list[Import]:
    """Every import of every module of the kit's packages."""
    found: list[Import] = []
    for root in SOURCE_ROOTS:
        for package in sorted(p for p in root.iterdir() if (p / "__init__.py").is_file()):
            for path in python_files(package):
                found += imports_of(path, root)
    return found


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one node, or a node importing itself
    (Tarjan's algorithm), each sorted; sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(edges.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1 or node in edges.get(node, ()):
                found.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            visit(node)
    return sorted(found)
