"""Reading ontology files, the type index, families, and file names of the docs."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from ontology_helpers import ONTOLOGY

from openair.protocol.matching import matches
from openair_ontology.model import Kind, TypeIndex, entry_matches
from openair_ontology.parse import OntologyError, encode_ontology, parse_ontology, read_ontology
from openair_ontology.paths import Paths, file_name


@pytest.fixture(scope="module")
def index() -> TypeIndex:
    return TypeIndex(read_ontology(ONTOLOGY))


def test_example_reads_with_the_seed_vocabulary(index: TypeIndex) -> None:
    sentence = index.get("Input.Perc.UniM.Hear.Voice.Speak.Sentence")
    assert sentence is not None and sentence.kind is Kind.MESSAGE
    assert [a.node.segment for a in index.ancestors(sentence)] == [
        "Input",
        "Perc",
        "UniM",
        "Hear",
        "Voice",
        "Speak",
    ]
    assert sentence.node.examples[0].is_xml
    assert '<entry name="text">come here please</entry>' in sentence.node.examples[0].content
    for name in ("MouseMotion", "Track", "Cmd2dMove", "DiffMotion"):
        assert any(e.node.segment == name for e in index.entries), name
    stream = index.get("Input.Audio.Perception")
    assert stream is not None and stream.kind is Kind.STREAM
    assert index.get("input.perc") is not None  # ASCII case ignored (OA-MATCH-1)
    retrieve = index.get("AIR.Retrieve")
    assert retrieve is not None and retrieve.kind is Kind.MESSAGE  # explicit kind with children
    group = index.get("Input.Perc")
    assert group is not None and group.kind is Kind.GROUP


def test_example_round_trips_through_the_writer() -> None:
    onto = read_ontology(ONTOLOGY)
    assert parse_ontology(encode_ontology(onto)) == onto


def test_families_resolve_their_members(index: TypeIndex) -> None:
    lost = index.resolve("Psyclone.Module.Lost.Reader")
    assert lost is not None and lost.display_name == "Psyclone.Module.Lost.{module}"
    context = index.resolve("Psyclone.Context:Psyclone.System.Ready")
    assert context is not None and context.display_name == "Psyclone.Context:{context}"
    assert index.resolve("Psyclone.Module.Lost") is None  # the family name alone is no member
    assert index.resolve("Psyclone.Module.Lostling") is None


@pytest.mark.parametrize(
    ("pattern", "expected"),
    [
        ("Psyclone.Module.Lost.*", True),
        ("Psyclone.Module.*", True),
        ("*", True),
        ("*.Reader", True),
        ("Psyclone.*.Reader", True),
        ("Psyclone.Module.L*", True),
        ("Psyclone.Module.Lost.Reader", True),
        ("Psyclone.Module.Lost", False),
        ("Psyclone.Module.Connect.*", False),
        ("Input.*", False),
        ("Psyclone.Module.Lost*", True),
    ],
)
def test_patterns_match_families_by_witness(index: TypeIndex, pattern: str, expected: bool) -> None:
    lost = index.get("Psyclone.Module.Lost")
    assert lost is not None
    assert entry_matches(pattern, lost) is expected


def test_groups_are_matched_by_no_pattern(index: TypeIndex) -> None:
    assert [e.name for e in index.matched_by("Input.Perc.*")] == [
        e.name for e in index.concrete() if e.name.startswith("Input.Perc.")
    ]
    group = index.get("Input.Perc")
    assert group is not None and not entry_matches("*", group)


def test_namespace_is_the_longest_prefix(index: TypeIndex) -> None:
    ns = index.namespace_of("Skundar.Decision.Cmd2dMove")
    assert ns is not None and ns.owner == "Skundar robot team"
    assert index.namespace_of("Inputs.X") is None


def _doc(body: str) -> bytes:
    return f'<ontology name="t">{body}</ontology>'.encode()


@pytest.mark.parametrize(
    ("body", "problem"),
    [
        ('<type segment="A"/><type segment="a"/>', "defined twice"),
        ('<type segment="A"><type segment="B"/><type segment="b"/></type>', "'A.b' is defined"),
        ('<type segment="A" parameter="p"><type segment="B"/></type>', "parameter and child"),
        ('<namespace prefix="A"/><namespace prefix="a"/>', "declared twice"),
    ],
)
def test_rules_the_schema_cannot_say_are_checked(body: str, problem: str) -> None:
    with pytest.raises(OntologyError, match=problem):
        parse_ontology(_doc(body), source="t.xml")


@pytest.mark.parametrize("segment", ["\u00e9\u200b", "a b", "x\u2028", "\U000e0001"])
def test_segment_characters_follow_the_unicode_table(segment: str) -> None:
    # OA-TYPE-5: the schema's segment pattern is the table of 5.1 (Cf, Zs, Zl, … excluded).
    with pytest.raises(OntologyError, match="segment"):
        parse_ontology(_doc(f'<type segment="{segment}"/>'), source="t.xml")
    parse_ontology(_doc('<type segment="\u00e9\u0378"/>'), source="t.xml")  # unassigned: allowed


def test_too_many_segments_are_refused() -> None:
    deep = '<type segment="S">' * 33 + "</type>" * 33
    with pytest.raises(OntologyError, match="more than 32 segments"):
        parse_ontology(_doc(deep))


@pytest.mark.parametrize(
    ("data", "problem"),
    [
        (b'<!DOCTYPE o [<!ENTITY e "x">]><ontology name="&e;"/>', "XML_FORBIDDEN"),
        (b"<ontology name='x'>", "XML_MALFORMED"),
        (b'<psySpec name="x"/>', "root must be ontology"),
        (b'<ontology name="x"><type segment="A.B"/></ontology>', r"t\.xml:1: .*segment"),
    ],
)
def test_bad_files_are_refused_with_a_line(data: bytes, problem: str) -> None:
    with pytest.raises(OntologyError, match=problem):
        parse_ontology(data, source="t.xml")


def test_missing_file_is_an_ontology_error() -> None:
    with pytest.raises(OntologyError, match="cannot read"):
        read_ontology("/nonexistent/ontology.xml")


@given(st.text(min_size=1, max_size=30))
def test_file_names_are_safe_and_distinct(name: str) -> None:
    safe = file_name(name)
    assert all(c.isascii() and (c.isalnum() or c in "-_.~") for c in safe)
    assert not safe.startswith(".") and "/" not in safe
    assert file_name(name + "x") != safe


def test_file_names_keep_ordinary_type_names() -> None:
    assert file_name("Input.Perc.UniM") == "Input.Perc.UniM"
    assert file_name("Psyclone.Context:A") == "Psyclone.Context~3AA"
    assert Paths(ext=".md").type("A/B") == "types/A~2FB.md"


def _chain(type_: str) -> bytes:
    """An ontology that defines `type_` as nested type nodes."""
    segments = type_.split(".")
    opening = "".join(f'<type segment="{s}">' for s in segments)
    return _doc(opening + "</type>" * len(segments))


@given(st.sampled_from(["A", "A.B", "A.B.C", "X.A.A", "Test.Ping"]), st.text("AB.*X", max_size=8))
def test_plain_entries_match_exactly_like_the_spec_matcher(type_: str, pattern: str) -> None:
    # For a type that is no family member, entry_matches is the spec matcher (OA-MATCH-1..6).
    entry = TypeIndex(parse_ontology(_chain(type_))).get(type_)
    assert entry is not None
    assert entry_matches(pattern, entry) is matches(pattern, type_)


def test_an_example_mixing_elements_and_text_is_read() -> None:
    """The schema allows mixed content in `<example>`; its elements are the example's content."""
    onto = parse_ontology(
        _doc('<type segment="A"><example><a>1</a>loose text<b/></example></type>')
    )
    (node,) = onto.types
    (example,) = node.examples
    assert example.content == "<a>1</a>\n<b/>" and example.language == "xml"
