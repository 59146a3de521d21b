"""PatternIndex behaviour, matcher edge cases and the Psyclone model's documented rules."""

from __future__ import annotations

import pytest

from openair.protocol.matching import PatternIndex, ascii_fold, matches, psyclone_matches

Key = tuple[str, int]


def test_index_routes_each_pattern_shape() -> None:
    index: PatternIndex[Key] = PatternIndex()
    index.add("Test.Ping", ("exact", 0))
    index.add("Test.*", ("subtree", 0))
    index.add("*", ("all", 0))
    index.add("Test.*.A", ("anchored glob", 0))
    index.add("*.A", ("loose glob", 0))
    assert len(index) == 5
    assert index.match("test.ping") == {("exact", 0), ("subtree", 0), ("all", 0)}
    assert index.match("Test") == {("subtree", 0), ("all", 0)}
    every = {("subtree", 0), ("all", 0), ("anchored glob", 0), ("loose glob", 0)}
    assert index.match("Test.X.A") == every
    assert index.match("Other.A") == {("all", 0), ("loose glob", 0)}


def test_index_pairs_are_a_set_and_patterns_fold() -> None:
    index: PatternIndex[int] = PatternIndex()
    index.add("Test.*", 1)
    index.add("TEST.*", 1)  # the same pattern after folding: no change
    index.add("test.*", 2)
    assert len(index) == 2
    index.remove("tEsT.*", 1)
    assert len(index) == 1
    assert index.match("Test.X") == {2}


def test_index_key_matched_by_two_patterns_is_reported_once() -> None:
    index: PatternIndex[str] = PatternIndex()
    index.add("A.*", "m")
    index.add("A.B", "m")
    index.add("*", "m")
    assert index.match("A.B") == {"m"}
    index.remove("*", "m")
    index.remove("A.*", "m")
    assert index.match("A.B") == {"m"}
    assert index.match("A.C") == set()


def test_index_remove_absent_pair_raises() -> None:
    index: PatternIndex[int] = PatternIndex()
    index.add("A.*", 1)
    with pytest.raises(KeyError):
        index.remove("A.*", 2)
    with pytest.raises(KeyError):
        index.remove("B.*", 1)
    with pytest.raises(KeyError):
        index.remove("A.*.C", 1)
    assert len(index) == 1


def test_index_clear_and_reuse() -> None:
    index: PatternIndex[int] = PatternIndex()
    for i, pattern in enumerate(["A", "A.*", "*", "A*B", "*.B"]):
        index.add(pattern, i)
    index.clear()
    assert len(index) == 0
    assert index.match("A.B") == set()
    index.add("A*B", 7)
    assert index.match("AxB") == {7}


def test_index_removing_everything_leaves_it_empty() -> None:
    index: PatternIndex[int] = PatternIndex()
    pairs = [("A", 1), ("A.*", 1), ("A.*.C", 2), ("*x", 3), ("*", 4)]
    for pattern, key in pairs:
        index.add(pattern, key)
    for pattern, key in pairs:
        index.remove(pattern, key)
    assert len(index) == 0
    assert index.match("A") == set()
    assert index.match("A.B.C") == set()
    # White-box: removed patterns leave no empty buckets behind (registrations churn for ever).
    assert not index._nodes
    assert not index._loose


def test_index_match_returns_a_fresh_set() -> None:
    index: PatternIndex[int] = PatternIndex()
    index.add("*", 1)
    found = index.match("A")
    found.add(99)
    assert index.match("A") == {1}


@pytest.mark.parametrize(
    ("pattern", "type_", "expected"),
    [
        ("A.*.B.*", "A.X.B", False),  # OA-MATCH-4: the root `A.*.B` is literal
        ("A.*.*", "A", False),  # OA-MATCH-4 applies once
        ("A.*.*", "A.X", False),
        ("A.*.*", "A.X.Y", True),
        ("*.*", "A", False),  # root of `*.*` is the literal `*`
        ("*.*", "A.B", True),
        ("Test.*.A", "Test.A", False),  # OA-MATCH-6 no overlap
        ("*.A", "X.A.A", True),  # OA-MATCH-6 no first-occurrence quirk
        ("\u00c4", "\u00e4", False),  # OA-MATCH-1 ASCII only
        ("*A*A*A*A*A*A*A*A*B", "A" * 250, False),  # linear, not exponential
    ],
)
def test_matches_edge_cases(pattern: str, type_: str, expected: bool) -> None:
    assert matches(pattern, type_) is expected


def test_ascii_fold_leaves_non_ascii_alone() -> None:
    assert ascii_fold("Test.PING") == "test.ping"
    assert ascii_fold("\u0130X.\u00c4b") == "\u0130x.\u00c4b"
    assert len(ascii_fold("\u0130" * 3)) == 3


@pytest.mark.parametrize(
    ("pattern", "type_", "expected"),
    [
        ("Test.Ping", "test.ping", True),  # rule 1: equality, case ignored
        ("Test.Ping", "Test.Ping.A", False),
        ("Test.Ping.*", "Test", True),  # rule 2: type is a prefix of the text before `*`
        ("Te*t.Ping", "T", True),
        ("*Test.Ping.A", "Test.Ping.AB", True),  # rule 3: leading `*`, common length agrees
        ("*Y", "XYX", False),
        ("*.A", "X.A.A", False),  # rule 4: first occurrence of the suffix must be at the end
        ("Test.*.A", "Test.A", True),  # rule 4: prefix and suffix overlap
        ("**", "AB", False),  # the second `*` is a literal
        ("Test.Ping", "*", True),  # a starred posted type acts as a wildcard
        ("*Ab", "A*", True),
        ("*.A", "A*", False),
    ],
)
def test_psyclone_model_rules(pattern: str, type_: str, expected: bool) -> None:
    assert psyclone_matches(pattern, type_) is expected
