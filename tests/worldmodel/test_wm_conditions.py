"""The condition language: the vectors, printing round trips, evaluation rules (OA-WM-10)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from openair_worldmodel.conditions import (
    FIELDS,
    KEYWORDS,
    And,
    Compare,
    Condition,
    ConditionSyntaxError,
    Const,
    Field,
    Literal,
    Not,
    Or,
    evaluate,
    parse_condition,
    to_text,
    to_tree,
)
from openair_worldmodel.packets import Packet, Ref

VECTORS = Path(__file__).resolve().parents[2] / "spec/vectors/worldmodel/conditions.json"
CASES = json.loads(VECTORS.read_text())["cases"]


@pytest.mark.parametrize("case", CASES, ids=lambda c: c["expression"][:40])
def test_vector(case: dict[str, Any]) -> None:
    if "tree" in case:
        assert to_tree(parse_condition(case["expression"])) == case["tree"]
    else:
        with pytest.raises(ConditionSyntaxError) as info:
            parse_condition(case["expression"])
        assert info.value.position == case["position"]
        assert info.value.name == case["error"]


def test_overlong_text_is_refused() -> None:
    with pytest.raises(ConditionSyntaxError):
        parse_condition("a.b.value < 1 or " * 300 + "true")


_segment = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,5}", fullmatch=True).filter(
    lambda s: s not in KEYWORDS
)
_fields = st.builds(
    Field,
    object=st.lists(_segment, min_size=1, max_size=3).map(".".join),
    attribute=_segment,
    field=st.sampled_from(FIELDS),
)
_literals = st.builds(
    Literal,
    value=st.one_of(
        st.floats(allow_nan=False, allow_infinity=False),
        st.text(max_size=8),
        st.builds(Ref, name=st.lists(_segment, min_size=1, max_size=2).map(".".join)),
    ),
)
_compares = st.builds(
    Compare,
    op=st.sampled_from(["==", "!=", "<", "<=", ">", ">="]),
    left=st.one_of(_fields, _literals),
    right=st.one_of(_fields, _literals),
)
conditions: st.SearchStrategy[Condition] = st.recursive(
    st.one_of(_compares, st.builds(Const, value=st.booleans())),
    lambda inner: st.one_of(
        st.builds(Not, operand=inner),
        st.builds(And, operands=st.lists(inner, min_size=2, max_size=3).map(tuple)),
        st.builds(Or, operands=st.lists(inner, min_size=2, max_size=3).map(tuple)),
    ),
    max_leaves=8,
)


@given(conditions)
def test_printed_conditions_parse_back_to_themselves(cond: Condition) -> None:
    assert parse_condition(to_text(cond)) == cond


@given(st.text(max_size=40))
def test_any_text_parses_or_is_content_invalid(text: str) -> None:
    try:
        parse_condition(text)
    except ConditionSyntaxError as exc:
        assert 0 <= exc.position <= len(text)


def _lookup(table: dict[tuple[str, str], Packet]) -> Any:
    return lambda obj, attr: table.get((obj, attr))


def test_evaluation_rules() -> None:
    table = {
        ("P", "x"): Packet(value=2.0, accuracy=0.1, confidence=0.8, timestamp=7),
        ("P", "s"): Packet(value="go"),
        ("P", "r"): Packet(value=Ref(name="Dock")),
    }
    look = _lookup(table)
    truth = {
        "P.x.value > 1 and P.x.accuracy < 0.2 and P.x.timestamp == 7": True,
        "P.x.confidence >= 0.9": False,
        'P.s.value == "go" and P.s.value < "h"': True,
        "P.r.value == @Dock and P.r.value != @Other": True,
        "P.r.value < @Dock": False,  # references compare only with == and !=
        'P.x.value == "2.0"': False,  # different kinds never compare
        "Q.x.value < 1": False,  # a missing object
        "not Q.x.value < 1": True,
        "P.x.value < 1 or true": True,
    }
    for text, expected in truth.items():
        assert evaluate(parse_condition(text), look) is expected, text
