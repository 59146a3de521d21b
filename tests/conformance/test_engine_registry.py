"""The case table: ID rules, registry validation against the catalogue, selection."""

from __future__ import annotations

import re

import pytest

from openair.catalogue import DEFAULT_SPEC, load_catalogue
from openair_conformance import registry
from openair_conformance.expectations import load_expectations
from openair_conformance.harness import CaseContext
from openair_conformance.model import CASE_ID_PATTERN, CaseInfo, Level
from openair_conformance.registry import RegistryError, all_cases, case, get_case, select_cases


def test_every_cited_requirement_exists_in_the_catalogue() -> None:
    catalogue = load_catalogue()
    unknown = {
        item.info.id: [r for r in item.info.requirements if r not in catalogue]
        for item in all_cases()
    }
    assert {k: v for k, v in unknown.items() if v} == {}


def test_cases_are_described_well_enough_to_dispute() -> None:
    for item in all_cases():
        assert re.match(CASE_ID_PATTERN, item.info.id)
        assert item.doc, f"{item.info.id} has no docstring"
        assert item.info.allowed, f"{item.info.id} lists no allowed behaviour"


def test_case_level_is_not_stronger_than_what_it_cites() -> None:
    # A failure of a case is FAIL only at level MUST: that level needs a MUST requirement.
    catalogue = load_catalogue()
    rank = {"MUST": 0, "SHOULD": 1, "MAY": 2, "INFO": 3}
    for item in all_cases():
        strongest = min(rank[catalogue[r].level] for r in item.info.requirements)
        assert rank[item.info.level.value] >= strongest, item.info.id


def test_all_cases_is_sorted_and_get_case_finds_each() -> None:
    cases = all_cases()
    ids = [c.info.id for c in cases]
    assert ids == sorted(ids)
    assert len(ids) >= 10
    assert get_case(ids[0]).info.id == ids[0]
    with pytest.raises(KeyError):
        get_case("NOPE-999")


@pytest.fixture
def empty_table(monkeypatch: pytest.MonkeyPatch) -> dict[str, registry.RegisteredCase]:
    table: dict[str, registry.RegisteredCase] = {}
    monkeypatch.setattr(registry, "_CASES", table)
    return table


async def _noop(ctx: CaseContext) -> None:
    return None


def test_duplicate_id_is_refused(empty_table: dict[str, registry.RegisteredCase]) -> None:
    case(id="TEST-001", title="t", section="1", requirements=("OA-GEN-1",))(_noop)

    async def other(ctx: CaseContext) -> None:
        return None

    with pytest.raises(RegistryError, match="duplicate case id TEST-001"):
        case(id="TEST-001", title="t", section="1", requirements=("OA-GEN-1",))(other)


def test_re_registering_the_same_function_is_harmless(
    empty_table: dict[str, registry.RegisteredCase],
) -> None:
    for _ in range(2):
        case(id="TEST-002", title="t", section="1", requirements=("OA-GEN-1",))(_noop)
    assert list(empty_table) == ["TEST-002"]


def test_retired_ids_are_never_reused(
    empty_table: dict[str, registry.RegisteredCase], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(registry, "RETIRED_IDS", frozenset({"TEST-003"}))
    with pytest.raises(RegistryError, match="retired"):
        case(id="TEST-003", title="t", section="1", requirements=("OA-GEN-1",))(_noop)


def test_a_case_must_be_async(empty_table: dict[str, registry.RegisteredCase]) -> None:
    def sync(ctx: CaseContext) -> None:
        return None

    with pytest.raises(RegistryError, match="async"):
        case(id="TEST-004", title="t", section="1", requirements=("OA-GEN-1",))(sync)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"id": "match-001"}, "does not match"),
        ({"id": "MATCH-1"}, "does not match"),
        ({"title": "two\nlines"}, "one non-empty line"),
        ({"section": "5.x"}, "invalid section"),
        ({"requirements": ()}, "at least one requirement"),
        ({"requirements": ("MATCH-6",)}, "invalid requirement id"),
    ],
)
def test_case_info_validates(changes: dict[str, object], message: str) -> None:
    fields: dict[str, object] = {
        "id": "MATCH-001",
        "title": "t",
        "section": "5.2",
        "requirements": ("OA-MATCH-6",),
        "level": Level.MUST,
    }
    fields.update(changes)
    with pytest.raises(ValueError, match=message):
        CaseInfo(**fields)  # type: ignore[arg-type]


def _info(case_id: str, section: str) -> registry.RegisteredCase:
    info = CaseInfo(
        id=case_id, title="t", section=section, requirements=("OA-GEN-1",), level=Level.MUST
    )
    return registry.RegisteredCase(info=info, fn=_noop)


def test_select_by_glob_and_section() -> None:
    items = [
        _info("SESS-001", "6.7"),
        _info("SESS-002", "6.3"),
        _info("MATCH-001", "5.2"),
        _info("WB-001", "7"),
        _info("X-001", "60.1"),
    ]

    def ids(selection: list[registry.RegisteredCase]) -> list[str]:
        return [c.info.id for c in selection]

    assert ids(select_cases(items)) == ids(items)
    assert ids(select_cases(items, globs=["SESS-*"])) == ["SESS-001", "SESS-002"]
    assert ids(select_cases(items, globs=["*-001"], sections=["6"])) == ["SESS-001"]
    assert ids(select_cases(items, sections=["6.3"])) == ["SESS-002"]
    assert ids(select_cases(items, sections=["7", "5"])) == ["MATCH-001", "WB-001"]
    assert ids(select_cases(items, globs=["sess-*"])) == []  # IDs are case-sensitive


def test_shipped_psyclone_expectations_cite_real_requirements_and_deviations() -> None:
    expectations = load_expectations("psyclone-1.1.7")
    assert expectations.implementation == "Psyclone 1.1.7"
    catalogue = load_catalogue()
    spec = DEFAULT_SPEC.read_text(encoding="utf-8")
    appendix = spec[spec.index("## Appendix A") :]
    known_ids = {c.info.id for c in all_cases()}
    for entry in expectations.entries:
        assert not entry.requirement or entry.requirement in catalogue, entry
        assert entry.deviation and f"**{entry.deviation} " in appendix, entry
        if "*" not in entry.case:
            assert entry.case in known_ids, entry


def test_requirement_sentences_quote_the_catalogue() -> None:
    info = get_case("SESS-001").info
    rows = registry.requirement_sentences(info)
    catalogue = load_catalogue()
    assert rows == [(r, catalogue[r].level, catalogue[r].text) for r in info.requirements]
    odd = CaseInfo(
        id="X-001", title="t", section="1", requirements=("OA-NOPE-1",), level=Level.MUST
    )
    assert registry.requirement_sentences(odd) == [("OA-NOPE-1", "?", "(not in the catalogue)")]
