"""Copies of the working tree to mutate, so the shared tree is never touched.

A copy holds the files git tracks or would track (`git ls-files -co --exclude-standard`), as
they are on disk now (edits included, deleted files skipped, symlinks kept as links so the
package's `_data` links resolve inside the copy). The tree hash names the coverage map: it
covers what decides behaviour (the reference, the suite, the spec and the schemas).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

__all__ = ["HASHED_FOLDERS", "copy_tree", "module_hash", "tracked_files", "tree_hash"]

#: The folders whose content the coverage map depends on.
HASHED_FOLDERS = ("reference/", "conformance/", "spec/", "schemas/")


def tracked_files(root: Path) -> list[str]:
    """Return the tracked and untracked-but-not-ignored files of `root` that exist, sorted."""
    out = subprocess.run(
        ["git", "-C", str(root), "ls-files", "-co", "--exclude-standard", "-z"],
        check=True,
        capture_output=True,
    ).stdout.decode("utf-8")
    names = {name for name in out.split("\0") if name}
    return sorted(n for n in names if (root / n).is_symlink() or (root / n).is_file())


def copy_tree(root: Path, dest: Path, files: Sequence[str]) -> None:
    """Make `dest` a fresh copy of `files` of `root` (whatever was at `dest` is removed)."""
    if dest.exists():
        shutil.rmtree(dest)
    for name in files:
        src, dst = root / name, dest / name
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_symlink():
            os.symlink(os.readlink(src), dst)
        else:
            # Others edit the tree meanwhile: a file removed since it was listed is skipped.
            with contextlib.suppress(FileNotFoundError):
                shutil.copy2(src, dst)


def tree_hash(root: Path, files: Sequence[str]) -> str:
    """Return a hash of the names and contents of the files under HASHED_FOLDERS."""
    digest = hashlib.sha256()
    for name in files:
        path = root / name
        if name.startswith(HASHED_FOLDERS) and path.is_file() and not path.is_symlink():
            digest.update(name.encode("utf-8") + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def module_hash(text: str) -> str:
    """Return the hash of a module's source that names its cosmic-ray session."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]
