"""Rules that explain unobservable mutants, the stratified sample, the independent faults.

Pure checks (no server): each rule's claim is checked by running the mutated code where it
says the behaviour is kept; the Wilson interval against known values; every independent
fault of tests/faults/independent.toml still applies once to the current source and compiles.
"""

from __future__ import annotations

import dataclasses
import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tools.mutation.campaign import _sample_order
from tools.mutation.faults import apply, load_faults
from tools.mutation.report import MutantRecord, module_rows, render
from tools.mutation.rules import IF_SURVIVES, PRE_JUDGE, classify

ROOT = Path(__file__).resolve().parents[2]

SOURCE = """\
from __future__ import annotations

import logging
from dataclasses import dataclass, field

__all__ = ["A", "B"]
log = logging.getLogger("x")


@dataclass(frozen=True, slots=True, kw_only=True)
class A:
    \"\"\"Doc.\"\"\"

    x: int
    y: int = 0
    z: int = field(default=1, repr=False, compare=False)


@dataclass(frozen=True, slots=True, kw_only=True)
class B:
    y: int = 0
    x: int


def f(a: int) -> int:
    log.info("a=%d", a + 1)
    return a + 1
"""


def _at(text: str, line: int, token: str, nth: int = 0) -> tuple[tuple[int, int], tuple[int, int]]:
    row = SOURCE.splitlines()[line - 1]
    col = -1
    for _ in range(nth + 1):
        col = row.index(token, col + 1)
    return (line, col), (line, col + len(token))


def _rule(line: int, token: str, nth: int = 0) -> tuple[str, str] | None:
    hit = classify(SOURCE, *_at(SOURCE, line, token, nth))
    return None if hit is None else (hit.when, hit.reason.split(":")[0])


def test_dataclass_flags_are_classified_by_what_the_flag_changes() -> None:
    assert _rule(10, "True", 0) == (IF_SURVIVES, "equivalent")  # frozen: loses the hash
    assert _rule(10, "True", 1) == (PRE_JUDGE, "unobservable over TCP")  # slots
    assert _rule(10, "True", 2) == (PRE_JUDGE, "equivalent")  # kw_only, order allows it
    assert _rule(19, "True", 2) is None  # kw_only on B: required after default, breaks
    assert _rule(16, "False", 0) == (IF_SURVIVES, "unobservable over TCP")  # field repr
    assert _rule(16, "False", 1) is None  # field compare: changes __eq__, judged
    assert _rule(16, "1", 0) is None  # a default value: judged


def test_the_kw_only_rule_matches_what_python_does() -> None:
    """The rule says kw_only=False keeps A and breaks B: exec both mutated classes."""
    head, b_part = SOURCE.split("\n\n\n@dataclass(frozen=True, slots=True, kw_only=True)\nclass B")
    a_mutated = head.replace("kw_only=True", "kw_only=False")
    namespace: dict[str, object] = {}
    exec(compile(a_mutated, "a", "exec"), namespace)
    assert dataclasses.is_dataclass(namespace["A"])
    b_mutated = "from dataclasses import dataclass\n@dataclass(kw_only=False)\nclass B" + b_part
    with pytest.raises(TypeError):
        exec(compile(b_mutated.split("\n\n\ndef f")[0], "b", "exec"), {})


def test_frozen_false_drops_the_hash_which_is_why_it_needs_the_judge() -> None:
    @dataclasses.dataclass(frozen=False)
    class Mutable:
        x: int = 0

    with pytest.raises(TypeError):
        hash(Mutable())


def test_logging_all_and_docstrings() -> None:
    assert _rule(26, "+") == (IF_SURVIVES, "unobservable over TCP")  # a log argument
    assert _rule(27, "+") is None  # the same expression returned: judged
    assert _rule(6, '"A"') == (PRE_JUDGE, "equivalent")  # __all__
    assert _rule(12, '"""Doc."""') == (PRE_JUDGE, "equivalent")
    assert _rule(25, "int", 0) is None  # annotations are another filter's


def test_sample_order_is_seeded_and_stable() -> None:
    keys = [f"m.py:{i:010x}:core/X:0" for i in range(50)]
    first = sorted(keys, key=lambda k: _sample_order(k, "15"))
    assert first == sorted(keys, key=lambda k: _sample_order(k, "15"))
    assert first != sorted(keys, key=lambda k: _sample_order(k, "16"))
    assert sorted(first) == sorted(keys)


def _records(killed: int, survived: int, not_run: int, rule: int = 0) -> list[MutantRecord]:
    out = []
    for i, status in enumerate(
        ["killed"] * killed + ["survived"] * survived + ["not-run"] * not_run + ["by-rule"] * rule
    ):
        why = "equivalent: why" if status == "by-rule" else ""
        record = MutantRecord(key=f"k{i}", module="m.py", line=i, operator="op", status=status)
        out.append(dataclasses.replace(record, rule=why))
    return out


def test_a_sampled_module_gets_a_wilson_interval() -> None:
    (row,) = module_rows(_records(9, 1, 30), {})
    assert row.sampled and row.rate == pytest.approx(0.9)
    low, high = row.interval() or (0.0, 0.0)
    assert low == pytest.approx(0.5958, abs=1e-3) and high == pytest.approx(0.9821, abs=1e-3)
    text = render(_records(9, 1, 30, rule=2), {})
    assert "sample of 10, 95 % CI 59.6 %–98.2 %" in text
    assert "- m.py: 2 × equivalent: why" in text  # by rule: listed, outside the rate
    (full,) = module_rows(_records(9, 1, 0), {})
    assert not full.sampled


def test_a_survivor_a_rule_explains_leaves_the_denominator() -> None:
    survivor = MutantRecord(
        key="s", module="m.py", line=1, operator="op", status="survived", rule="x"
    )
    records = [*_records(9, 0, 0), survivor]
    (row,) = module_rows(records, {})
    assert row.equivalent == 1 and row.rate == 1.0
    assert "(rule) x" in render(records, {})


def test_independent_faults_apply_once_compile_and_cite_real_requirements() -> None:
    spec = (ROOT / "spec" / "openair-1.0.md").read_text(encoding="utf-8")
    known = set(re.findall(r"\*\*(OA-[A-Z]+-\d+)\*\*", spec))
    faults = load_faults()
    assert len(faults) >= 20
    for fault in faults:
        source = (ROOT / fault.file).read_text(encoding="utf-8")
        compile(apply(fault, source), fault.file, "exec")
        assert set(fault.requirements) <= known, fault.id
    with pytest.raises(ValueError, match="occurs 0 times"):
        apply(dataclasses.replace(faults[0], old="no such text anywhere"), "x = 1\n")


def test_explanations_by_mutant_line_or_function() -> None:
    from tools.mutation.report import explain
    from tools.mutation.rules import enclosing_function

    assert enclosing_function(SOURCE, 26) == "f"
    assert enclosing_function(SOURCE, 14) == ""  # a class body, no function
    base = MutantRecord(
        key="m.py:abc:core/X:0",
        module="m.py",
        line=3,
        operator="core/X",
        status="survived",
        function="C.g",
        line_key="m.py:abc",
    )
    assert explain(base, {}) == ""
    assert explain(base, {"m.py:def:C.g": "equivalent: f"}) == "equivalent: f"
    assert explain(base, {"m.py:abc": "equivalent: l", "m.py:def:C.g": "x"}) == "equivalent: l"
    assert explain(base, {"m.py:abc:core/X:0": "equivalent: k", "m.py:abc": "x"}) == (
        "equivalent: k"
    )
    other = dataclasses.replace(base, function="C.h", line_key="m.py:def")
    text = render([base, other], {"m.py:def:C.g": "equivalent: f", "m.py:def:Gone": "x"})
    assert "- `m.py:def:Gone`" in text and "- `m.py:def:C.g`" not in text  # stale listed


MARKED = """\
def g(a, *, b=64 * 1024):
    return a


def h(
    a,
    *,
    b=2,
):
    return a
"""


def test_the_keyword_only_marker_turned_into_a_slash_needs_the_judge() -> None:
    def at(line: int, col: int) -> tuple[str, str] | None:
        hit = classify(MARKED, (line, col), (line, col + 1))
        return None if hit is None else (hit.when, hit.reason.split(":")[0])

    row = MARKED.splitlines()[0]
    assert at(1, row.index("*")) == (IF_SURVIVES, "equivalent")  # the marker of g
    assert at(1, row.index("* 1024")) is None  # a multiplication in a default value
    assert at(7, 4) == (IF_SURVIVES, "equivalent")  # the marker of h, on its own line
    namespace: dict[str, object] = {}
    exec(compile(MARKED.replace("*,", "/,"), "m", "exec"), namespace)  # it does compile
