"""The shared vectors of spec 9.2 (content globs) and 5.1 (the character table) hold here."""

from __future__ import annotations

import itertools
import json
import unicodedata
from typing import Any

import pytest

from openair.protocol.contentmatch import canonical_xml_text, text_content
from openair.protocol.types import EXCLUDED_RANGES, is_valid_pattern, is_valid_type
from openair.resources import spec_path
from openair.server.core.whiteboard import content_glob

CONTENT_ROWS: list[dict[str, Any]] = json.loads(
    spec_path("vectors/contentmatch/contentmatch.json").read_text(encoding="utf-8")
)["rows"]
TABLE: dict[str, Any] = json.loads(
    spec_path("vectors/unicode/segment-exclusions.json").read_text(encoding="utf-8")
)
_EXCLUDED = frozenset({"Cc", "Cf", "Cs", "Co", "Zs", "Zl", "Zp"})


@pytest.mark.parametrize("row", CONTENT_ROWS, ids=[r["name"] for r in CONTENT_ROWS])
def test_canonical_xml_text_and_text_content(row: dict[str, Any]) -> None:
    """OA-RET-17 and OA-RET-18 on every row, and the canonical text is a fixed point."""
    assert canonical_xml_text(row["content"]) == row["canonical"]
    assert text_content(row["content"]) == row["text"]
    assert canonical_xml_text(row["canonical"]) == row["canonical"]
    assert text_content(row["canonical"]) == row["text"]


def test_the_spec_examples_select_as_9_2_says() -> None:
    """`*<c/>*` selects `<c></c>` through OA-RET-17; `xy`, not `x y`, is the text content."""
    indented = "<a  x='1'>\n  <b>y</b>\n  <c></c>\n</a>"
    assert content_glob("*<c/>*")(canonical_xml_text(indented))
    assert not content_glob("*<c></c>*")(canonical_xml_text(indented))
    assert content_glob("xy")(text_content("<a>x</a> <b>y</b>"))
    assert not content_glob("x y")(text_content("<a>x</a> <b>y</b>"))


def test_the_table_is_what_the_reference_reads() -> None:
    ranges = [(int(r["first"][2:], 16), int(r["last"][2:], 16)) for r in TABLE["ranges"]]
    assert tuple(ranges) == EXCLUDED_RANGES
    assert all(a <= b < c for (a, b), (c, _) in itertools.pairwise(ranges))
    assert {r["category"] for r in TABLE["ranges"]} == _EXCLUDED


@pytest.mark.skipif(unicodedata.unidata_version != "14.0.0", reason="needs Unicode 14.0.0 data")
def test_the_table_is_unicode_14_general_categories() -> None:
    """The vector file is exactly the code points of the excluded categories (its origin)."""
    inside = {cp for a, b in EXCLUDED_RANGES for cp in range(a, b + 1)}
    expected = {cp for cp in range(0x110000) if unicodedata.category(chr(cp)) in _EXCLUDED}
    assert inside == expected


@pytest.mark.parametrize(("first", "last"), EXCLUDED_RANGES[:: max(1, len(EXCLUDED_RANGES) // 12)])
def test_range_ends_are_refused_in_types_and_patterns(first: int, last: int) -> None:
    """OA-TYPE-5: both ends of a range make a type and a pattern invalid."""
    for cp in (first, last):
        assert not is_valid_type(f"A{chr(cp)}B")
        assert not is_valid_pattern(f"A{chr(cp)}*")


def test_unassigned_code_points_are_segment_characters() -> None:
    """OA-TYPE-5: Cn in Unicode 14.0.0 is accepted, whatever the runtime's data says."""
    assert is_valid_type("A\u0378B")
    assert is_valid_type("A\U00013439B")
