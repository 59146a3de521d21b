#!/usr/bin/env python3
"""Generate the requirements catalogue (spec/requirements.xml) from the spec prose.

Usage: gen_catalogue.py [--check]. With --check, exit 1 if the committed catalogue differs from a
fresh extraction of spec/openair-1.0.md (exit 2 if the prose breaks the requirement format).
The extraction rules live in reference/openair/catalogue.py, which the conformance suite shares.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from openair.catalogue import CatalogueError, extract_requirements, render_catalogue

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "spec" / "openair-1.0.md"
CATALOGUE = ROOT / "spec" / "requirements.xml"


def _shown(path: Path) -> str:
    """Return `path` relative to the project when it lies inside it."""
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def build(spec: Path = SPEC) -> bytes:
    """Return the catalogue XML extracted from the spec prose."""
    return render_catalogue(extract_requirements(spec.read_text(encoding="utf-8")))


def main(argv: list[str] | None = None) -> int:
    """Write (or with --check, verify) spec/requirements.xml."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true", help="fail if the catalogue is stale")
    args = ap.parse_args(argv)
    try:
        data = build()
    except CatalogueError as exc:
        print(f"{_shown(SPEC)}: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if not CATALOGUE.exists() or CATALOGUE.read_bytes() != data:
            stale = _shown(CATALOGUE)
            print(f"stale generated file (run `make generate`): {stale}", file=sys.stderr)
            return 1
        return 0
    CATALOGUE.write_bytes(data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
