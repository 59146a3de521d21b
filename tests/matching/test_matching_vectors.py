"""The shared wildcard vector table (spec/vectors/wildcards) against the reference matchers."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from openair.protocol.errors import PatternInvalidError, TypeInvalidError
from openair.protocol.matching import PatternIndex, matches, psyclone_matches
from openair.protocol.types import is_valid_pattern, is_valid_type, validate_pattern, validate_type

VECTORS = Path(__file__).resolve().parents[2] / "spec" / "vectors" / "wildcards" / "wildcards.json"
TABLE: dict[str, Any] = json.loads(VECTORS.read_text(encoding="utf-8"))
ROWS: list[dict[str, str]] = TABLE["rows"]


def _row_id(row: dict[str, str]) -> str:
    return f"{row['pattern'][:30]!r}~{row['type'][:30]!r}"


def _spec_answer(pattern: str, type_: str) -> str:
    """Classify a row the way the table does (the pattern is checked first)."""
    if not is_valid_pattern(pattern):
        return "invalid-pattern"
    if not is_valid_type(type_):
        return "invalid-type"
    return "match" if matches(pattern, type_) else "nomatch"


@pytest.mark.parametrize("row", ROWS, ids=_row_id)
def test_spec_answer(row: dict[str, str]) -> None:
    assert _spec_answer(row["pattern"], row["type"]) == row["expected"]


@pytest.mark.parametrize("row", ROWS, ids=_row_id)
def test_psyclone_model(row: dict[str, str]) -> None:
    # For observed rows this checks the model against the real server's answers.
    answer = "match" if psyclone_matches(row["pattern"], row["type"]) else "nomatch"
    assert answer == row["psyclone"]


@pytest.mark.parametrize(
    "row", [r for r in ROWS if r["expected"].startswith("invalid")], ids=_row_id
)
def test_invalid_rows_raise_the_table_error(row: dict[str, str]) -> None:
    if row["expected"] == "invalid-pattern":
        with pytest.raises(PatternInvalidError):
            validate_pattern(row["pattern"])
    else:
        assert validate_pattern(row["pattern"]) == row["pattern"]
        with pytest.raises(TypeInvalidError):
            validate_type(row["type"])


def test_table_has_every_observed_run() -> None:
    runs = Counter(
        row["source"].rsplit(" ", 1)[0] if "retrieves" not in row["source"] else row["source"]
        for row in ROWS
        if row["basis"] == "observed"
    )
    assert runs == {
        "psyclone-wire/09-wildcards.txt run 1": 19 * 19,
        "psyclone-wire/09-wildcards.txt run 2": 10 * 23,
        "psyclone-wire/09-wildcards.txt run 3 triggers": 10 * 19,
        "psyclone-wire/09-wildcards.txt run 3 retrieves (latest=0)": 13 * 16,
    }


def test_table_values_are_well_formed() -> None:
    assert TABLE["format"] == "openair-wildcard-vectors/1"
    for row in ROWS:
        assert row["expected"] in TABLE["expected_values"]
        assert row["psyclone"] in ("match", "nomatch")
        assert row["basis"] in ("observed", "model")
        assert row["source"]


def test_table_shows_the_d4_deviations() -> None:
    # D4: `Test.Ping.*` vs `Test` is a Psyclone match but a spec nomatch, and so on.
    wanted = {
        ("Test.Ping.*", "Test"): ("nomatch", "match"),
        ("Test.*.A", "Test.A"): ("nomatch", "match"),
        ("*.A", "X.A.A"): ("match", "nomatch"),
        ("Input.Perc.*", "Input.Perc"): ("match", "match"),
    }
    seen = {(r["pattern"], r["type"]): (r["expected"], r["psyclone"]) for r in ROWS}
    for pair, answers in wanted.items():
        assert seen[pair] == answers


def test_index_agrees_with_matches_over_the_table() -> None:
    patterns = sorted({r["pattern"] for r in ROWS if is_valid_pattern(r["pattern"])})
    types = sorted({r["type"] for r in ROWS if is_valid_type(r["type"])})
    index: PatternIndex[str] = PatternIndex()
    for pattern in patterns:
        index.add(pattern, pattern)
    for type_ in types:
        assert index.match(type_) == {p for p in patterns if matches(p, type_)}, type_
