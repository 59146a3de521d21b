"""Property tests: matches() against a regex reference, PatternIndex against matches()."""

from __future__ import annotations

import re

from hypothesis import given
from hypothesis import strategies as st
from hypothesis.stateful import Bundle, RuleBasedStateMachine, invariant, rule

from openair.protocol.matching import PatternIndex, ascii_fold, matcher, matches
from openair.protocol.types import is_valid_pattern, is_valid_type

# --- an independent statement of OA-MATCH-1..6 as a regular expression --------------------------


def _glob_regex(pattern: str) -> str:
    return "".join(".*" if char == "*" else re.escape(char) for char in pattern)


def reference_matches(pattern: str, type_: str) -> bool:
    """Whole-type match, `*` = any run (dots included), ASCII case ignored, `P.*` also matches P."""
    alternatives = [_glob_regex(pattern)]
    if pattern.endswith(".*"):
        alternatives.append(re.escape(pattern[:-2]))  # OA-MATCH-4: the root is literal
    regex = "|".join(f"(?:{alt})" for alt in alternatives)
    return re.fullmatch(regex, type_, re.ASCII | re.IGNORECASE | re.DOTALL) is not None


# --- strategies: a small alphabet so that matches actually happen --------------------------------

segments = st.sampled_from(["a", "b", "A", "ab", "Ba", "a:b"])
types = st.lists(segments, min_size=1, max_size=4).map(".".join)
glob_segments = st.text(alphabet="aAb*", min_size=1, max_size=3).filter(lambda s: "**" not in s)


@st.composite
def patterns(draw: st.DrawFn) -> str:
    """Draw a valid pattern: exact, `Prefix.*`, `*`, a general glob, or one bent from a type."""
    kind = draw(st.sampled_from(["exact", "subtree", "all", "glob", "bent"]))
    if kind == "exact":
        return draw(types)
    if kind == "subtree":
        return draw(types) + ".*"
    if kind == "all":
        return "*"
    if kind == "glob":
        return ".".join(draw(st.lists(glob_segments, min_size=1, max_size=4)))
    parts = draw(types).split(".")
    bent = [draw(st.sampled_from([part, "*", part + "*", "*" + part[1:]])) for part in parts]
    pattern = ".".join(seg if seg else "*" for seg in bent)
    return pattern.replace("**", "*")


keys = st.integers(min_value=0, max_value=5)


@given(patterns(), types)
def test_generated_inputs_are_valid(pattern: str, type_: str) -> None:
    assert is_valid_pattern(pattern)
    assert is_valid_type(type_)


@given(patterns(), types)
def test_matches_equals_regex_reference(pattern: str, type_: str) -> None:
    assert matches(pattern, type_) == reference_matches(pattern, type_)


@given(patterns(), st.lists(types, max_size=6))
def test_compiled_matcher_equals_matches(pattern: str, probes: list[str]) -> None:
    # `matcher` compiles once (and tests `Prefix.*` as a prefix): the same answers (issue #19).
    test = matcher(pattern)
    for type_ in [*probes, pattern.removesuffix(".*"), pattern.removesuffix("*")]:
        if is_valid_type(type_):
            assert test(type_) == matches(pattern, type_), (pattern, type_)


@given(patterns(), types)
def test_matching_ignores_ascii_case(pattern: str, type_: str) -> None:
    assert matches(pattern.upper(), type_.lower()) == matches(pattern, type_)


@given(types)
def test_subtree_pattern_matches_root_and_descendants(type_: str) -> None:
    # OA-MATCH-4, OA-MATCH-3: `T.*` matches T, T.x and T.x.y but not the parent of T.
    assert matches(type_ + ".*", type_)
    assert matches(type_ + ".*", type_ + ".x.y")
    assert matches("*", type_)
    parent, _, _ = type_.rpartition(".")
    if parent:
        assert not matches(type_ + ".*", parent)


@given(st.lists(st.tuples(patterns(), keys), max_size=30), st.lists(types, max_size=10))
def test_index_agrees_with_matches(pairs: list[tuple[str, int]], probes: list[str]) -> None:
    index: PatternIndex[int] = PatternIndex()
    for pattern, key in pairs:
        index.add(pattern, key)
    for type_ in probes:
        assert index.match(type_) == {k for p, k in pairs if matches(p, type_)}


# The index claims agreement with matches() even on unvalidated strings.
loose_text = st.text(alphabet="aA.*:", max_size=6)


@given(st.lists(st.tuples(loose_text, keys), max_size=20), st.lists(loose_text, max_size=10))
def test_index_agrees_with_matches_on_any_strings(
    pairs: list[tuple[str, int]], probes: list[str]
) -> None:
    index: PatternIndex[int] = PatternIndex()
    for pattern, key in pairs:
        index.add(pattern, key)
    for type_ in probes:
        assert index.match(type_) == {k for p, k in pairs if matches(p, type_)}


@given(
    st.lists(st.tuples(patterns(), keys), max_size=30),
    st.data(),
    st.lists(types, min_size=1, max_size=8),
)
def test_index_add_remove_keeps_agreement(
    pairs: list[tuple[str, int]], data: st.DataObject, probes: list[str]
) -> None:
    index: PatternIndex[int] = PatternIndex()
    for pattern, key in pairs:
        index.add(pattern, key)
    held = {(ascii_fold(p), k) for p, k in pairs}
    assert len(index) == len(held)
    removed = data.draw(st.lists(st.sampled_from(pairs), unique=True) if pairs else st.just([]))
    for pattern, key in removed:
        folded = (ascii_fold(pattern), key)
        if folded in held:
            index.remove(pattern.swapcase(), key)  # removal folds the pattern too
            held.discard(folded)
    assert len(index) == len(held)
    for type_ in probes:
        assert index.match(type_) == {k for p, k in held if matches(p, type_)}


class IndexMachine(RuleBasedStateMachine):
    """Random add / remove / clear sequences against a plain set of (folded pattern, key) pairs."""

    def __init__(self) -> None:
        super().__init__()
        self.index: PatternIndex[int] = PatternIndex()
        self.model: set[tuple[str, int]] = set()

    added = Bundle("added")

    @rule(target=added, pattern=patterns(), key=keys)
    def add(self, pattern: str, key: int) -> tuple[str, int]:
        self.index.add(pattern, key)
        self.model.add((ascii_fold(pattern), key))
        return pattern, key

    @rule(pair=added)
    def remove(self, pair: tuple[str, int]) -> None:
        pattern, key = pair
        if (ascii_fold(pattern), key) in self.model:
            self.index.remove(pattern, key)
            self.model.discard((ascii_fold(pattern), key))
        else:
            try:
                self.index.remove(pattern, key)
            except KeyError:
                pass
            else:
                raise AssertionError("removing an absent pair must raise KeyError")

    @rule()
    def clear(self) -> None:
        self.index.clear()
        self.model.clear()

    @rule(type_=types)
    def match(self, type_: str) -> None:
        assert self.index.match(type_) == {k for p, k in self.model if matches(p, type_)}

    @invariant()
    def length(self) -> None:
        assert len(self.index) == len(self.model)


TestIndexMachine = IndexMachine.TestCase
