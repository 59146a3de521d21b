#!/usr/bin/env python3
"""Generate (or check) the Java binding's error enum from the spec's single error table.

Usage: gen_errors_java.py [--check]. Writes bindings/java/src/main/java/org/openair/ErrorCode.java
from spec/errors.xml; with --check, exit 1 if that file is stale or missing.

The table loading and the Java rendering are gen_errors.py's (`load_rows`, `java_source`), so the
file this tool writes is byte-identical to the one `gen_errors.py` writes once bindings/java
exists: the two generators can never disagree, and `make check-generated` stays green whichever
runs last. This tool only lets the Java build regenerate or verify its one file on its own.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

TOOLS = Path(__file__).resolve().parent
ROOT = TOOLS.parent
TARGET = ROOT / "bindings" / "java" / "src" / "main" / "java" / "org" / "openair" / "ErrorCode.java"


def _gen_errors() -> ModuleType:
    """Import tools/gen_errors.py by path (tools/ is not a package)."""
    spec = importlib.util.spec_from_file_location("gen_errors", TOOLS / "gen_errors.py")
    if spec is None or spec.loader is None:
        raise SystemExit("tools/gen_errors.py not found")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("gen_errors", module)  # dataclasses look their module up by name
    spec.loader.exec_module(module)
    return module


def main(argv: list[str] | None = None) -> int:
    """Write (or with --check, verify) ErrorCode.java."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true", help="fail if ErrorCode.java is stale")
    ap.add_argument("--out", type=Path, default=TARGET, help="where the enum is written")
    args = ap.parse_args(argv)
    gen = _gen_errors()
    text: str = gen.java_source(gen.load_rows())
    out: Path = args.out.resolve()
    if args.check:
        if not out.exists() or out.read_text(encoding="utf-8") != text:
            print(f"stale generated file (run tools/gen_errors_java.py): {out}", file=sys.stderr)
            return 1
        return 0
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
