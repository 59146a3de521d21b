"""Retrieve specifications (spec 9.2, 9.4): every criterion as element or attribute."""

from __future__ import annotations

from pathlib import Path

import pytest
from objects_helpers import content_schema, doc_content, doc_paths, schema_errors

from openair.protocol.content import ContentMatch, RetrieveSpec
from openair.protocol.errors import (
    ApiMisuseError,
    PatternInvalidError,
    RetrieveInvalidError,
    XmlForbiddenError,
)
from openair.protocol.registration import (
    encode_retrieve,
    encode_retrieves,
    parse_retrieve_element,
    parse_retrieves,
)
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import parse_fragment


def one(content: str) -> RetrieveSpec:
    (spec,) = parse_retrieves(content)
    return spec


# The Part B matrix of psyclone-wire/05-retrieve.txt, as sent (verbatim).
MATRIX = [
    (
        '<retrieve from="WB1" type="Ret.A.*"><latest>3</latest></retrieve>',
        RetrieveSpec(whiteboard="WB1", pattern="Ret.A.*", latest=3),
    ),
    ('<retrieve from="WB1" type="Ret.A.*"/>', RetrieveSpec(whiteboard="WB1", pattern="Ret.A.*")),
    (
        '<retrieve from="WB1" type="Ret.*"><latest>0</latest></retrieve>',
        RetrieveSpec(whiteboard="WB1", pattern="Ret.*", latest=0),
    ),
    (
        '<retrieve from="WB1" type="Ret.*" latest="2"/>',
        RetrieveSpec(whiteboard="WB1", pattern="Ret.*", latest=2),
    ),
    (
        '<retrieve from="WB1"><latest>3</latest></retrieve>',
        RetrieveSpec(whiteboard="WB1", latest=3),
    ),
    (
        '<retrieve type="Ret.A.*"><latest>3</latest></retrieve>',
        RetrieveSpec(pattern="Ret.A.*", latest=3),
    ),
    (
        '<retrieve from="WB1" type="*.1"><latest>5</latest></retrieve>',
        RetrieveSpec(whiteboard="WB1", pattern="*.1", latest=5),
    ),
    (
        '<retrieve from="WB1" type="Ret.*" content="*tomato*"><latest>10</latest></retrieve>',
        RetrieveSpec(whiteboard="WB1", pattern="Ret.*", content="*tomato*", latest=10),
    ),
    (
        '<retrieve from="WB1" type="Ret.*" sender="Poster"><latest>2</latest></retrieve>',
        RetrieveSpec(whiteboard="WB1", pattern="Ret.*", sender="Poster", latest=2),
    ),
    (
        '<retrieve from="WB1" type="Ret.A.*"><latest>2</latest>'
        "<lastmsec>100000</lastmsec></retrieve>",
        RetrieveSpec(whiteboard="WB1", pattern="Ret.A.*", latest=2, lastmsec=100000),
    ),
    (
        '<retrieve from="WB1" type="Ret.*"><lastmsec>250</lastmsec></retrieve>',
        RetrieveSpec(whiteboard="WB1", pattern="Ret.*", lastmsec=250),
    ),
    (
        '<retrieve from="wb1" type="Ret.A.*"><latest>2</latest></retrieve>',
        RetrieveSpec(whiteboard="wb1", pattern="Ret.A.*", latest=2),
    ),  # OA-RET-2: exact case
]


@pytest.mark.parametrize(("content", "expected"), MATRIX)
def test_psyclone_matrix_specs(content: str, expected: RetrieveSpec) -> None:
    assert one(content) == expected
    assert one(encode_retrieve(expected)) == expected


def test_retrieves_keep_order_and_group_from() -> None:
    specs = parse_retrieves(
        '<retrieves><retrieve from="WB1" type="Ret.B.*"><latest>1</latest></retrieve>'
        '<retrieve from="WB2" type="*"><latest>1</latest></retrieve></retrieves>'
    )
    assert [(s.whiteboard, s.pattern) for s in specs] == [("WB1", "Ret.B.*"), ("WB2", "*")]
    specs = parse_retrieves(
        '<retrieves from="WB1"><retrieve/><retrieve from="WB2"/><retrieve from=""/></retrieves>'
    )
    assert [s.whiteboard for s in specs] == ["WB1", "WB2", "WB1"]  # OA-REG-5


def test_psyclone_echo_with_empty_attributes() -> None:
    # psyclone-wire/05-retrieve.txt: a registration retrieve as Psyclone echoes it (verbatim).
    content = (
        '<retrieve from="WB1" sender="" type="TR.Data.*" id="" content="" '
        'contentmatch="">\n\t<latest>2</latest>\n</retrieve>'
    )
    assert one(content) == RetrieveSpec(whiteboard="WB1", pattern="TR.Data.*", latest=2)


def test_every_attribute_criterion_in_any_case() -> None:
    spec = one(
        '<RETRIEVE FROM="WB1" Type="A.*" ID="i-1" SENDER="Poster" Content="*x?*" '
        'CONTENTMATCH="XML" LATEST="4" LastMsec="500" AFTERTIME="1000" untiltime="2001"/>'
    )
    assert spec == RetrieveSpec(
        whiteboard="WB1",
        pattern="A.*",
        id="i-1",
        sender="Poster",
        content="*x?*",
        contentmatch=ContentMatch.XML,
        latest=4,
        lastmsec=500,
        after_time=AirTime(sec=1, msec=0),
        until_time=AirTime(sec=2, msec=1),
    )


@pytest.mark.parametrize("value", ["", "text", "TEXT", "Text"])
def test_contentmatch_text_forms(value: str) -> None:
    assert one(f'<retrieve contentmatch="{value}"/>').contentmatch is ContentMatch.TEXT


@pytest.mark.parametrize(
    "child",
    [
        '<afterTime><time sec="1795330126" msec="764"/></afterTime>',
        '<AfterTime><Time SEC="1795330126" MS="764" tzc="Greenwich_0_60"/></AfterTime>',
        '<aftertime><when sec="1795330126" msec="764"/></aftertime>',
        "<afterTime> 1795330126764 </afterTime>",
    ],
)
def test_time_bounds_as_child_element_or_epoch_ms(child: str) -> None:
    spec = one(f"<retrieve>{child}</retrieve>")
    assert spec.after_time == AirTime(sec=1795330126, msec=764)  # OA-RET-9


def test_time_bound_keeps_usec_and_negative_epoch_ms() -> None:
    spec = one(
        '<retrieve><untilTime><time sec="5" msec="1" usec="2"/></untilTime>'
        "<afterTime>-1500</afterTime></retrieve>"
    )
    assert spec.until_time == AirTime(sec=5, msec=1, usec=2)
    assert spec.after_time == AirTime(sec=-2, msec=500)


def test_same_value_twice_is_accepted() -> None:
    # The sample time-bounds-all-forms.xml: untilTime as attribute and element, equal.
    spec = one(
        '<retrieve untilTime="1795330190148" latest="2" afterTime=""><untilTime>'
        "1795330190148</untilTime><latest>2</latest></retrieve>"
    )
    assert spec.until_time == AirTime(sec=1795330190, msec=148)
    assert spec.latest == 2
    assert spec.after_time is None  # spec 9.2: an empty attribute is an absent one


def test_unknown_criteria_are_ignored() -> None:
    # OA-RET-16: undefined attributes and children are ignored.
    spec = one('<retrieve maxcount="3" type="A"><maxcount>3</maxcount><mincount/></retrieve>')
    assert spec == RetrieveSpec(pattern="A")


@pytest.mark.parametrize(
    "content",
    [
        "",
        "  ",
        "garbage",  # Psyclone answers everything (DEV-14); OpenAIR refuses
        "<retrieve",
        "<retrieves/>",
        '<retrieves from="WB1"/>',
        "<retrieves><trigger type='X'/></retrieves>",
        "<retrieve/><retrieve/>",
        "<trigger type='X'/>",
        "<retrieve><latest>all</latest></retrieve>",
        "<retrieve><latest></latest></retrieve>",
        "<retrieve><latest><n>1</n></latest></retrieve>",
        "<retrieve latest='-1'/>",
        "<retrieve latest='1.5'/>",
        "<retrieve latest='2'><latest>3</latest></retrieve>",  # OA-RET-4
        "<retrieve><latest>2</latest><latest>3</latest></retrieve>",
        "<retrieve><latest>99999999999999999999</latest></retrieve>",
        "<retrieve><lastmsec>-250</lastmsec></retrieve>",
        "<retrieve lastmsec='soon'/>",
        "<retrieve content='t.*o' contentmatch='regex'/>",
        "<retrieve afterTime='22.11.2026 06:35:22.548'/>",
        "<retrieve><untilTime><time sec='soon' msec='0'/></untilTime></retrieve>",
        "<retrieve><untilTime><time msec='0'/></untilTime></retrieve>",
        "<retrieve><afterTime><time sec='1' msec='0'/><time sec='2' msec='0'/></afterTime>"
        "</retrieve>",
        "<retrieve><afterTime>5<time sec='1' msec='0'/></afterTime></retrieve>",
        "<retrieve><afterTime></afterTime></retrieve>",
        "<retrieve afterTime='1000'><afterTime>2000</afterTime></retrieve>",
        "<retrieve><beforecontext>SoB.Alive</beforecontext></retrieve>",  # OA-RET-16
        "<retrieve duringcontext='SoB.Alive'/>",
        "<retrieve><after>SoB.Alive</after></retrieve>",
        "<retrieve before='X'/>",
    ],
)
def test_malformed_retrieves_are_retrieve_invalid(content: str) -> None:
    with pytest.raises(RetrieveInvalidError):
        parse_retrieves(content)  # OA-RET-10


@pytest.mark.parametrize("pattern", ["**", "Ret..A", "A B", ".A", "***"])
def test_invalid_patterns_are_pattern_invalid(pattern: str) -> None:
    with pytest.raises(PatternInvalidError):
        parse_retrieves(f'<retrieve type="{pattern}"/>')  # OA-MATCH-7


def test_hostile_xml_keeps_its_own_condition() -> None:
    with pytest.raises(XmlForbiddenError):
        parse_retrieves('<!DOCTYPE r [<!ENTITY x "y">]><retrieve/>')


def test_parse_retrieve_element_refuses_other_elements() -> None:
    (el,) = parse_fragment('<retrieve from="WB1"/>')
    assert parse_retrieve_element(el) == RetrieveSpec(whiteboard="WB1")
    (el,) = parse_fragment("<retrieves/>")
    with pytest.raises(RetrieveInvalidError):
        parse_retrieve_element(el)


# --- writing --------------------------------------------------------------------------------


def test_encode_writes_the_canonical_spelling() -> None:
    spec = RetrieveSpec(
        whiteboard="WB1",
        pattern="A.*",
        contentmatch=ContentMatch.XML,
        content="*<b>*",
        lastmsec=250,
        after_time=AirTime(sec=1, msec=2),
        until_time=AirTime(sec=3, msec=4, usec=5),
    )
    assert encode_retrieve(spec) == (
        '<retrieve from="WB1" type="A.*" content="*&lt;b&gt;*" contentmatch="xml">'
        "<latest>1</latest><lastmsec>250</lastmsec><afterTime>1002</afterTime>"
        '<untilTime><time sec="3" msec="4" usec="5"/></untilTime></retrieve>'
    )
    assert one(encode_retrieve(spec)) == spec


def test_encode_retrieves_needs_one_spec_and_valid_values() -> None:
    with pytest.raises(ApiMisuseError):
        encode_retrieves([])
    with pytest.raises(ApiMisuseError):
        encode_retrieve(RetrieveSpec(latest=-1))
    with pytest.raises(ApiMisuseError):
        encode_retrieve(RetrieveSpec(lastmsec=-1))
    with pytest.raises(ApiMisuseError):
        encode_retrieve(RetrieveSpec(pattern="A..B"))
    with pytest.raises(ApiMisuseError):
        encode_retrieve(RetrieveSpec(sender="\x00"))


def test_encoded_retrieves_validate() -> None:
    specs = [one(c) for c, _ in MATRIX]
    text = encode_retrieves(specs)
    assert parse_retrieves(text) == tuple(specs)
    assert schema_errors(content_schema(), text, "retrieves") == ""


# --- the sample documents of tests/schemas/docs/retrieve ------------------------------------

# Schema-invalid samples that receivers accept: OA-RET-16 ignores unknown children.
LENIENT = {"unknown-child"}


@pytest.mark.parametrize(
    "path",
    [p for p in doc_paths("retrieve", "valid") if p.stem != "context-criteria"],
    ids=lambda p: p.stem,
)
def test_valid_retrieve_samples_are_accepted_and_round_trip(path: Path) -> None:
    specs = parse_retrieves(doc_content(path))
    assert parse_retrieves(encode_retrieves(specs)) == specs
    for spec in specs:
        assert schema_errors(content_schema(), encode_retrieve(spec), "retrieve") == ""


def test_context_criteria_sample_is_refused_without_an_implementation() -> None:
    (path,) = [p for p in doc_paths("retrieve", "valid") if p.stem == "context-criteria"]
    with pytest.raises(RetrieveInvalidError, match="context criterion"):
        parse_retrieves(doc_content(path))  # OA-RET-16


@pytest.mark.parametrize(
    "path",
    [p for p in doc_paths("retrieve", "invalid") if p.stem not in LENIENT],
    ids=lambda p: p.stem,
)
def test_invalid_retrieve_samples_are_refused(path: Path) -> None:
    with pytest.raises((RetrieveInvalidError, PatternInvalidError)):
        parse_retrieves(doc_content(path))
