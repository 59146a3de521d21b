"""Paths to the data files shipped inside the package (XSD schemas, spec tables).

`_data/schemas` and `_data/spec` are symlinks to the top-level `schemas/` and `spec/` folders in
a source tree, and real folders in an installed wheel; either way the paths below work.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["DATA_DIR", "schema_path", "spec_path"]

DATA_DIR = Path(__file__).parent / "_data"


def _inside(folder: str, name: str) -> Path:
    """Return `_data/<folder>/<name>`, refusing names that would leave that folder."""
    if not name or Path(name).is_absolute() or ".." in Path(name).parts:
        raise ValueError(f"not a data file name: {name!r}")
    return DATA_DIR / folder / name


def schema_path(name: str) -> Path:
    """Return the path of the shipped schema `name` (for example `psyspec.xsd`)."""
    return _inside("schemas", name)


def spec_path(name: str) -> Path:
    """Return the path of the shipped spec file `name` (for example `errors.xml`)."""
    return _inside("spec", name)
