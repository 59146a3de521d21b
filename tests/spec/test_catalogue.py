"""The requirements catalogue: generated from the prose, valid, complete, and cited correctly.

These tests are the guard that spec/requirements.xml is current, that every requirement ID of the
skeleton and the error table exists, and that no code under reference/, conformance/ or tools/
cites an unknown requirement ID (the code is scanned at test time).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType

import pytest
import xmlschema
from hypothesis import given
from hypothesis import strategies as st
from lxml import etree

from openair.catalogue import (
    ID_PATTERN,
    CatalogueError,
    Requirement,
    cited_ids,
    extract_requirements,
    find_stray_keywords,
    load_catalogue,
    render_catalogue,
)

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "spec" / "openair-1.0.md"
CATALOGUE = ROOT / "spec" / "requirements.xml"
SCHEMA = ROOT / "schemas" / "requirements.xsd"
SKELETON = ROOT / "spec" / "SKELETON.md"
ERRORS = ROOT / "spec" / "errors.xml"
CODE_DIRS = ("reference", "conformance", "tools")

_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)


def _prose() -> str:
    return SPEC.read_text(encoding="utf-8")


def _catalogue_ids_in_file_order() -> list[str]:
    root = etree.parse(str(CATALOGUE), _PARSER).getroot()
    return [el.get("id", "") for el in root.iterchildren("requirement")]


# --- the committed catalogue -----------------------------------------------------------------


def test_committed_catalogue_equals_fresh_extraction() -> None:
    fresh = render_catalogue(extract_requirements(_prose()))
    assert CATALOGUE.read_bytes() == fresh, "spec/requirements.xml is stale: run `make generate`"


def test_catalogue_is_valid_for_lxml() -> None:
    schema = etree.XMLSchema(etree.parse(str(SCHEMA), _PARSER))
    doc = etree.parse(str(CATALOGUE), _PARSER)
    assert schema.validate(doc), schema.error_log


def test_catalogue_is_valid_for_xmlschema() -> None:
    schema = xmlschema.XMLSchema10(str(SCHEMA))
    schema.validate(str(CATALOGUE))


def test_schema_rejects_a_duplicate_id_and_a_bad_level() -> None:
    schema = etree.XMLSchema(etree.parse(str(SCHEMA), _PARSER))
    dup = (
        b'<requirements spec="OpenAIR" version="1.0">'
        b'<requirement id="OA-X-1" level="MUST" section="1">a</requirement>'
        b'<requirement id="OA-X-1" level="MUST" section="1">b</requirement></requirements>'
    )
    bad_level = dup.replace(b'level="MUST" section="1">b', b'level="MUSTN" section="1">b')
    bad_level = bad_level.replace(b'id="OA-X-1" level="MUSTN"', b'id="OA-X-2" level="MUSTN"')
    assert not schema.validate(etree.fromstring(dup, _PARSER))
    assert not schema.validate(etree.fromstring(bad_level, _PARSER))
    assert not xmlschema.XMLSchema10(str(SCHEMA)).is_valid(dup.decode())


def test_ids_are_unique_and_well_formed() -> None:
    ids = _catalogue_ids_in_file_order()
    assert ids, "the catalogue is empty"
    assert len(ids) == len(set(ids)), [i for i in ids if ids.count(i) > 1]
    bad = [i for i in ids if not re.fullmatch(ID_PATTERN, i)]
    assert not bad


def test_load_catalogue_reads_the_shipped_file() -> None:
    # The default path goes through reference/openair/_data/spec, the symlink the wheel ships.
    loaded = load_catalogue()
    assert list(loaded) == _catalogue_ids_in_file_order()
    assert loaded == {r.id: r for r in extract_requirements(_prose())}


def test_every_level_and_some_extensions_occur() -> None:
    catalogue = load_catalogue(CATALOGUE)
    assert {r.level for r in catalogue.values()} == {"MUST", "SHOULD", "MAY"}
    assert catalogue["OA-XSTREAM-1"].extension == "typed-streams"
    assert catalogue["OA-FRAME-1"].extension is None


# --- cross references ------------------------------------------------------------------------


def test_every_skeleton_id_exists() -> None:
    missing = cited_ids(SKELETON.read_text(encoding="utf-8")) - set(load_catalogue(CATALOGUE))
    assert not missing, sorted(missing)


def test_every_id_cited_in_the_error_table_exists() -> None:
    root = etree.parse(str(ERRORS), _PARSER).getroot()
    in_attributes = {i for el in root.iter("error") for i in (el.get("requirement") or "").split()}
    in_text = cited_ids(ERRORS.read_text(encoding="utf-8"))
    assert in_attributes <= in_text
    missing = in_text - set(load_catalogue(CATALOGUE))
    assert not missing, sorted(missing)


def _python_files() -> list[Path]:
    files: list[Path] = []
    for top in CODE_DIRS:
        for path in sorted((ROOT / top).rglob("*.py")):
            parts = path.relative_to(ROOT).parts
            # _data holds symlinks to spec/ and schemas/, not code; caches are not code either.
            if "_data" in parts or "__pycache__" in parts:
                continue
            files.append(path)
    return files


def test_code_cites_only_known_ids() -> None:
    known = set(load_catalogue(CATALOGUE))
    files = _python_files()
    assert any(p.name == "catalogue.py" for p in files)  # the scan does see the code
    unknown = {
        f"{path.relative_to(ROOT)}: {req_id}"
        for path in files
        for req_id in cited_ids(path.read_text(encoding="utf-8"))
        if req_id not in known
    }
    assert not unknown, sorted(unknown)


def test_prose_cites_only_known_ids() -> None:
    prose = _prose()
    unknown = cited_ids(prose) - {r.id for r in extract_requirements(prose)}
    assert not unknown, sorted(unknown)


def test_prose_uses_capital_keywords_only_in_requirements() -> None:
    assert find_stray_keywords(_prose()) == []


def _prose_error_rows() -> dict[int, tuple[str, str, str, str, str]]:
    prose = _prose()
    section = prose[prose.index("\n## 13 Errors") : prose.index("\n## 14 ")]
    rows: dict[int, tuple[str, str, str, str, str]] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 7 and cells[0].isdigit():
            reply = "-" if cells[3] == "—" else cells[3]
            reqs = " ".join(cells[5].replace(",", " ").split())
            rows[int(cells[0])] = (cells[1].strip("`"), cells[2], reply, cells[4], reqs)
    return rows


def test_prose_error_table_matches_errors_xml() -> None:
    root = etree.parse(str(ERRORS), _PARSER).getroot()
    expected = {
        int(el.get("code", "")): (
            el.get("name", ""),
            el.get("blame", ""),
            el.get("reply", ""),
            el.get("closes", ""),
            " ".join((el.get("requirement") or "").split()),
        )
        for el in root.iter("error")
    }
    assert _prose_error_rows() == expected


# --- the generator ---------------------------------------------------------------------------


def _load_tool() -> ModuleType:
    path = ROOT / "tools" / "gen_catalogue.py"
    spec = importlib.util.spec_from_file_location("gen_catalogue", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generator_check_detects_a_stale_file_and_write_fixes_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    tool = _load_tool()
    target = tmp_path / "requirements.xml"
    target.write_bytes(b"<requirements/>")
    monkeypatch.setattr(tool, "CATALOGUE", target)
    assert tool.main(["--check"]) == 1
    assert tool.main([]) == 0
    assert tool.main(["--check"]) == 0
    assert target.read_bytes() == CATALOGUE.read_bytes()


# --- the extractor ---------------------------------------------------------------------------


def _doc(*paragraphs: str, heading: str = "## 6 The session") -> str:
    return "# Title\n\n" + heading + "\n\n" + "\n\n".join(paragraphs) + "\n"


def test_extract_levels_sections_text_and_extension() -> None:
    md = (
        "# Title\n\n## 1 Conventions\n\nProse.\n\n"
        "**OA-A-1** A peer MUST NOT send `**` or *emphasis*; it MAY\nwrap lines.\n\n"
        "### 1.2 Sub\n\n"
        "**OA-A-2** Use of `MUST` in code does not count; this is NOT RECOMMENDED.\n\n"
        "```\n**OA-A-9** MUST is inside a fence\n```\n\n"
        "- **OA-A-3** A list item is OPTIONAL (extension `noreply`), see [the table](#x).\n"
    )
    reqs = extract_requirements(md)
    assert reqs == [
        Requirement(
            id="OA-A-1",
            level="MUST",
            section="1",
            text="A peer MUST NOT send ** or emphasis; it MAY wrap lines.",
        ),
        Requirement(
            id="OA-A-2",
            level="SHOULD",
            section="1.2",
            text="Use of MUST in code does not count; this is NOT RECOMMENDED.",
        ),
        Requirement(
            id="OA-A-3",
            level="MAY",
            section="1.2",
            text="A list item is OPTIONAL (extension noreply), see the table.",
            extension="noreply",
        ),
    ]


@pytest.mark.parametrize(
    ("keyword", "level"),
    [
        ("REQUIRED", "MUST"),
        ("SHALL", "MUST"),
        ("SHALL NOT", "MUST"),
        ("SHOULD NOT", "SHOULD"),
        ("RECOMMENDED", "SHOULD"),
        ("MAY", "MAY"),
    ],
)
def test_first_keyword_gives_the_level(keyword: str, level: str) -> None:
    (req,) = extract_requirements(_doc(f"**OA-B-1** It is {keyword} here, and MUST there."))
    assert req.level == level


def test_paragraph_without_keyword_is_an_error() -> None:
    with pytest.raises(CatalogueError, match="OA-B-1 has no RFC 2119"):
        extract_requirements(_doc("**OA-B-1** A peer must do this (lower case)."))


def test_keyword_only_in_code_is_an_error() -> None:
    with pytest.raises(CatalogueError, match="no RFC 2119"):
        extract_requirements(_doc("**OA-B-1** The word `MUST` is code here."))


def test_duplicate_id_is_an_error() -> None:
    with pytest.raises(CatalogueError, match="duplicate requirement OA-B-1"):
        extract_requirements(_doc("**OA-B-1** One MUST.", "**OA-B-1** Two MUST."))


def test_malformed_id_is_an_error() -> None:
    with pytest.raises(CatalogueError, match="malformed"):
        extract_requirements(_doc("**OA-b-1** Lower-case group MUST fail."))


def test_requirement_outside_a_numbered_section_is_an_error() -> None:
    with pytest.raises(CatalogueError, match="not inside a numbered section"):
        extract_requirements(_doc("**OA-B-1** Appendix text MUST fail.", heading="## Appendix A"))


def test_two_extensions_in_one_requirement_is_an_error() -> None:
    text = "**OA-B-1** It MUST (extension `usec`) and (extension `noreply`)."
    with pytest.raises(CatalogueError, match="several extensions"):
        extract_requirements(_doc(text))


def test_stray_keywords_are_found_outside_requirements_and_quotes() -> None:
    md = _doc('The words "MUST" and "MAY" are quoted.', "But this SHOULD be flagged.", "`MAY`")
    assert find_stray_keywords(md) == [(7, "SHOULD")]


def test_load_catalogue_rejects_duplicates(tmp_path: Path) -> None:
    path = tmp_path / "requirements.xml"
    req = Requirement(id="OA-C-1", level="MAY", section="2", text="x MAY y")
    path.write_bytes(render_catalogue([req, req]))
    with pytest.raises(CatalogueError, match="duplicate"):
        load_catalogue(path)


def test_requirement_validates_its_fields() -> None:
    with pytest.raises(CatalogueError):
        Requirement(id="OA-C-1", level="MUST NOT", section="2", text="t")
    with pytest.raises(CatalogueError):
        Requirement(id="OA-C-1", level="MUST", section="A", text="t")
    with pytest.raises(CatalogueError):
        Requirement(id="OA-C-1", level="MUST", section="2", text="t", extension="Bad Name")


_words = st.text(alphabet="abcdefghij klmnop", min_size=1, max_size=40).map(str.strip)


@given(
    numbers=st.lists(st.integers(min_value=1, max_value=999), min_size=1, max_size=8, unique=True),
    keyword=st.sampled_from(["MUST", "SHOULD", "MAY"]),
    words=_words.filter(bool),
)
def test_round_trip_through_the_catalogue_file(
    tmp_path_factory: pytest.TempPathFactory, numbers: list[int], keyword: str, words: str
) -> None:
    md = _doc(*(f"**OA-R-{n}** {words} {keyword} {n}." for n in numbers))
    reqs = extract_requirements(md)
    assert [r.id for r in reqs] == [f"OA-R-{n}" for n in numbers]
    assert {r.level for r in reqs} == {keyword}
    path = tmp_path_factory.mktemp("cat") / "requirements.xml"
    path.write_bytes(render_catalogue(reqs))
    assert list(load_catalogue(path).values()) == reqs
