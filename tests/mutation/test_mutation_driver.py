"""The mutation-testing machinery (tools/mutation): keys, case selection, report, the judge.

The judge test copies the tree, records a small coverage map (the RET-00x cases) in the copy,
and judges a flipped comparison in whiteboard.py (must be killed), a mutation on a line no case
runs (survives without a run) and the unmutated copy (must survive).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

# `tools` is a folder of the repository, not an installed package.
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tools.mutation import MODULE_GROUPS, resolve_modules
from tools.mutation.report import MutantRecord, load_explanations, module_rows, render
from tools.mutation.selection import (
    STARTUP,
    TEARDOWN,
    MutantSite,
    annotation_spans,
    changed_lines,
    in_spans,
    mutant_keys,
    recorded_lines,
    select_cases_for,
)
from tools.mutation.snapshot import copy_tree, tracked_files

ROOT = Path(__file__).resolve().parents[2]
WHITEBOARD = "reference/openair/server/core/whiteboard.py"

SOURCE = """\
LIMIT = 3


def f(a, b):
    if a < b and b < LIMIT:
        return a + 1
    return b - 1


@staticmethod
def g(x=2):
    total = (x +
             1)
    return total
"""


def _sites(source: str, module: str = "m.py") -> list[MutantSite]:
    """Sites as cosmic-ray numbers them: `occurrence` counts per operator over the module."""
    sites, counts = [], {"lt": 0, "add": 0}
    for n, text in enumerate(source.splitlines(), start=1):
        for op, token in (("lt", " <"), ("add", " +")):
            col = text.find(token)
            while col >= 0:
                sites.append(
                    MutantSite(
                        job_id=f"job-{n}-{col}-{op}",
                        module=module,
                        line=n,
                        column=col,
                        operator=op,
                        occurrence=counts[op],
                    )
                )
                counts[op] += 1
                col = text.find(token, col + 1)
    return sites


def test_keys_survive_code_added_elsewhere() -> None:
    """Inserting code (with the same operators) above shifts lines and occurrences, not keys."""
    before = mutant_keys(_sites(SOURCE), {"m.py": SOURCE})
    edited = "def h(p, q):\n    return p < q + 1\n\n\n" + SOURCE
    after = mutant_keys(_sites(edited), {"m.py": edited})
    by_text_before = {k for k in before.values()}
    assert len(by_text_before) == len(before) == 4  # two `<` on one line: ranks 0 and 1
    assert by_text_before <= set(after.values())
    assert len(set(after.values())) == 6
    assert all(k.startswith("m.py:") for k in after.values())


def test_changed_lines_and_the_lines_coverage_records() -> None:
    mutated = SOURCE.replace("(x +\n             1)", "(x -\n             1)")
    assert changed_lines(SOURCE, mutated) == [12]
    assert changed_lines(SOURCE, SOURCE) == []
    # A continuation line stands for its statement; a decorated def for its decorator line.
    assert recorded_lines(SOURCE, [13]) == {12, 13}
    assert recorded_lines(SOURCE, [11]) >= {10, 11}
    assert recorded_lines(SOURCE, [5]) == {5}


def test_case_selection_from_a_coverage_map() -> None:
    cmap = {
        "m.py": {
            1: frozenset({STARTUP}),
            4: frozenset({STARTUP}),
            5: frozenset({"A-001", "B-001", "X-001"}),
            6: frozenset({"B-001"}),
            10: frozenset({STARTUP}),
            12: frozenset({"C-001"}),
            14: frozenset({TEARDOWN}),
        }
    }
    passing = ["B-001", "C-001", "A-001"]  # fastest first; X-001 failed on the clean server

    def pick(*lines: int) -> tuple[str, tuple[str, ...]]:
        s = select_cases_for(cmap, "m.py", SOURCE, list(lines), passing)
        return s.kind, s.cases

    assert pick(5) == ("cases", ("B-001", "A-001"))
    assert pick(6) == ("cases", ("B-001",))
    assert pick(13) == ("cases", ("C-001",))  # continuation of the statement on line 12
    assert pick(4) == ("cases", ("B-001", "A-001"))  # a def line: the cases running its body
    assert pick(1) == ("startup", tuple(passing))  # a module constant: every passing case
    assert pick(7) == ("not-executed", ())
    assert pick(14) == ("not-executed", ())  # run only at shutdown
    assert select_cases_for(cmap, "other.py", SOURCE, [5], passing).kind == "not-executed"


def test_mutants_in_annotations_are_found_only_under_postponed_evaluation() -> None:
    source = (
        "from __future__ import annotations\n"
        "def f(a: int | None, b=1 | 2) -> dict[str, int | None]:\n"
        "    x: float | None = a | b\n"
    )
    spans = annotation_spans(source)
    pipes = [i for i, ch in enumerate(source.splitlines()[1]) if ch == "|"]
    inside = [in_spans(spans, (2, col - 1), (2, col + 2)) for col in pipes]
    assert inside == [True, False, True]  # `1 | 2` is a default value: evaluated
    assert in_spans(spans, (3, 9), (3, 16)) and not in_spans(spans, (3, 21), (3, 24))
    assert annotation_spans(source.split("\n", 1)[1]) == []  # evaluated without the import


def test_cases_that_need_other_limits_get_a_server_of_their_own() -> None:
    from tools.mutation.serving import by_limits

    assert by_limits(["A-001", "DELIV-003", "B-001", "FRAME-018"]) == [
        ((), ["A-001", "B-001"]),
        ((("max_queue", 300),), ["DELIV-003"]),
        ((("frame_deadline_ms", 400),), ["FRAME-018"]),
    ]
    assert by_limits(["DELIV-003"]) == [((("max_queue", 300),), ["DELIV-003"])]


def test_a_case_with_several_sets_of_limits_runs_under_each() -> None:
    from tools.mutation.serving import CASE_LIMITS, by_limits

    more = CASE_LIMITS["DELIV-013"][1]
    assert more and dict(more)["delivery_retries"] > 2  # beyond the default two retries
    assert by_limits(["DELIV-013", "A-001"]) == [
        ((), ["DELIV-013", "A-001"]),
        (more, ["DELIV-013"]),
    ]
    groups = by_limits([f"LIM-00{n}" for n in range(1, 5)])  # one server for the four
    assert len(groups) == 1 and groups[0][0] != () and len(groups[0][1]) == 4


def test_a_mutated_keyword_only_marker_is_invalid_not_killed() -> None:
    """cosmic-ray also "replaces" the `*` of `def f(a, *, b)`; such a mutant must not count."""
    pytest.importorskip("cosmic_ray")
    from cosmic_ray.work_item import MutationSpec  # type: ignore[import-untyped]

    from tools.mutation.campaign import _compiles

    source = "def f(a, *, b):\n    return a * b\n"
    op = "core/ReplaceBinaryOperator_Mul_Add"
    spec = [MutationSpec("m.py", op, n, (1, 0), (1, 1)) for n in range(3)]
    assert [_compiles(source, m) for m in spec] == [False, True, True]  # the 3rd: no mutation


def _record(key: str, status: str, module: str = "a.py", **kw: object) -> MutantRecord:
    return MutantRecord(key=key, module=module, line=3, operator="op", status=status, **kw)  # type: ignore[arg-type]


def test_report_counts_rates_and_explanations(tmp_path: Path) -> None:
    records = [
        *[_record(f"a.py:k:op:{i}", "killed", seconds=2.0) for i in range(7)],
        _record("a.py:t:op:0", "timeout"),
        _record("a.py:s:op:0", "survived", diff="--- a\n+++ b\n@@ -3 +3 @@\n-x < y\n+x > y"),
        _record("a.py:s:op:1", "survived"),
        _record("a.py:n:op:0", "not-executed"),
        _record("a.py:r:op:0", "not-run"),
        _record("a.py:a:op:0", "skipped"),
        _record("a.py:i:op:0", "invalid"),
        _record("b.py:k:op:0", "killed", module="b.py", seconds=6.0),
    ]
    explanations = {
        "a.py:s:op:1": "equivalent: the two branches return the same value",
        "a.py:k:op:0": "equivalent: stale, the suite kills it",
    }
    rows = {r.module: r for r in module_rows(records, explanations)}
    a = rows["a.py"]
    assert (a.generated, a.judged, a.equivalent, a.unexplained) == (14, 11, 1, 2)
    assert a.rate == pytest.approx(8 / 10)
    assert rows["b.py"].rate == 1.0
    text = render(records, explanations, header=["run of today"])
    counts = "| 14 | 11 | 7 | 1 | 2 | 1 | 1 | 2 | 1 | 0 | 1 | 0 | 1 |"
    sample = "sample of 11, 95 % CI 49.0 %–94.3 %"  # one mutant not run: a sample
    assert f"| other | a.py {counts} 80.0 % **below target** | {sample} |" in text
    b_counts = "| 1 | 1 | 1 | 0 | 0 | 0 | 0 | 0 | 0 | 0 | 0 | 0 | 0 |"
    assert f"| other | b.py {b_counts} 100.0 % | full |" in text
    assert text.count("**UNEXPLAINED**") == 2
    assert "a.py:3 op (0 cases): equivalent: the two branches" in text
    assert "  +x > y" in text and "+++ b" not in text
    assert "- `a.py:k:op:0`" in text  # explained, yet killed: stale
    assert "mean 2.5 s" in text
    bad = tmp_path / "bad.toml"
    bad.write_text('[mutants]\n"a.py:s:op:0" = "looks fine"\n', encoding="utf-8")
    with pytest.raises(ValueError, match="one line starting"):
        load_explanations(bad)


def test_committed_explanations_are_well_formed_and_modules_resolve() -> None:
    committed = load_explanations(ROOT / "tools" / "mutation" / "equivalent.toml")
    every = set(resolve_modules([]))
    for key in committed:  # a mutant, `module:linehash` or `module:def:Name`, of a listed module
        module, _, rest = key.partition(":")
        assert module in every and rest and len(rest.split(":")) in (1, 2, 3), key
    assert resolve_modules(["whiteboard", "queues"]) == [
        WHITEBOARD,
        "reference/openair/server/core/queues.py",
    ]
    assert len(resolve_modules([])) == sum(len(p) for p in MODULE_GROUPS.values())
    with pytest.raises(ValueError):
        resolve_modules(["nonesuch"])


def _python(copy: Path, *args: str) -> subprocess.CompletedProcess[str]:
    path = os.pathsep.join(str(copy / p) for p in ("reference", "conformance", "."))
    env = {**os.environ, "PYTHONPATH": path, "PYTHONDONTWRITEBYTECODE": "1"}
    return subprocess.run(
        [sys.executable, *args], cwd=copy, env=env, capture_output=True, text=True, timeout=240
    )


def _judge(copy: Path, pristine: Path, cmap: Path) -> tuple[int, dict[str, object]]:
    done = _python(
        copy, "-m", "tools.mutation.judge", "--map", str(cmap), "--pristine", str(pristine)
    )
    assert done.stdout.strip(), done.stderr
    return done.returncode, json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_the_judge_kills_a_flipped_comparison_and_spares_the_clean_server(tmp_path: Path) -> None:
    pytest.importorskip("coverage")  # the `mutation` extra
    files = tracked_files(ROOT)
    pristine, work = tmp_path / "pristine", tmp_path / "work"
    copy_tree(ROOT, pristine, files)
    copy_tree(ROOT, work, files)
    cmap = tmp_path / "map.json"
    control = _python(
        pristine, "-m", "tools.mutation.control", "--out", str(cmap), "--case=RET-00?", WHITEBOARD
    )
    assert control.returncode == 0, control.stderr
    original = (work / WHITEBOARD).read_text(encoding="utf-8")
    flipped = original.replace("if len(found) == limit:", "if len(found) != limit:")
    assert flipped != original
    (work / WHITEBOARD).write_text(flipped, encoding="utf-8")
    code, record = _judge(work, pristine, cmap)
    assert (code, record["verdict"], record["kind"]) == (1, "killed", "cases"), record
    assert str(record["killer"]).startswith("RET-")
    unrun = original.replace(
        "self._last_ns = newest.ms * _NS_PER_MS", "self._last_ns = 0 * _NS_PER_MS"
    )
    assert unrun != original  # _reload runs only with a durable store, which no case uses
    (work / WHITEBOARD).write_text(unrun, encoding="utf-8")
    code, record = _judge(work, pristine, cmap)
    assert (code, record["verdict"], record["kind"]) == (0, "survived", "not-executed"), record
    (work / WHITEBOARD).write_text(original, encoding="utf-8")
    code, record = _judge(work, pristine, cmap)
    assert (code, record["verdict"], record["kind"]) == (0, "survived", "baseline"), record
    assert record["cases"] == len(json.loads(cmap.read_text(encoding="utf-8"))["cases"])
