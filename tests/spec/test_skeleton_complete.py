"""spec/SKELETON.md names every requirement of the catalogue, with its level, and nothing else.

The skeleton is the short map of requirement IDs that code and cases cite; a requirement added to
the spec without a skeleton line (or a line left behind by a removed one) fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

from openair.catalogue import load_catalogue

SKELETON = Path(__file__).resolve().parents[2] / "spec" / "SKELETON.md"
_LINE = re.compile(r"^- (OA-[A-Z]+-\d+) (MUST|SHOULD|MAY|MUST NOT|SHOULD NOT)\b", re.M)


def _skeleton() -> dict[str, str]:
    return {m.group(1): m.group(2) for m in _LINE.finditer(SKELETON.read_text(encoding="utf-8"))}


def test_every_requirement_has_a_skeleton_line() -> None:
    listed = _skeleton()
    missing = sorted(set(load_catalogue()) - set(listed))
    assert not missing, f"requirements missing from spec/SKELETON.md: {missing}"


def test_skeleton_lines_name_requirements_that_exist_with_their_level() -> None:
    catalogue = load_catalogue()
    listed = _skeleton()
    unknown = sorted(set(listed) - set(catalogue))
    assert not unknown, f"spec/SKELETON.md lists requirements the spec does not: {unknown}"
    wrong = sorted(i for i, level in listed.items() if catalogue[i].level != level)
    assert not wrong, f"levels differ from the spec: {wrong}"
