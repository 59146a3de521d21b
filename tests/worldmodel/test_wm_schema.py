"""schemas/worldmodel.xsd: lxml and xmlschema agree on every sample, and so does the reader."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import xmlschema
from lxml import etree

from openair.protocol.errors import ContentInvalidError, XmlForbiddenError, XmlTooDeepError
from openair_worldmodel import wire

ROOT = Path(__file__).resolve().parents[2]
XSD = ROOT / "schemas" / "worldmodel.xsd"
DOCS = ROOT / "tests" / "schemas" / "docs" / "worldmodel"
MESSAGES = json.loads((ROOT / "spec/vectors/worldmodel/messages.json").read_text())["cases"]
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
_LIBXML2 = etree.XMLSchema(etree.parse(str(XSD), _PARSER))
_PURE: Any = xmlschema.XMLSchema10(str(XSD))
DECODERS = {
    "WM.Report": wire.decode_report,
    "WM.Class": wire.decode_class,
    "WM.Plan": wire.decode_plan,
    "WM.Plan.Ack": wire.decode_ack,
    "WM.Plan.Cancel": wire.decode_cancel,
    "WM.Hello": wire.decode_hello,
}
SAMPLES = [(v, p) for v in ("valid", "invalid") for p in sorted((DOCS / v).glob("*.xml"))]


def test_there_are_samples_of_every_root_both_ways() -> None:
    for verdict in ("valid", "invalid"):
        roots = {etree.parse(str(p), _PARSER).getroot().tag for v, p in SAMPLES if v == verdict}
        assert len(roots) >= 5, (verdict, roots)


@pytest.mark.parametrize(("verdict", "path"), SAMPLES, ids=lambda x: getattr(x, "name", x))
def test_both_validators_give_the_folder_verdict(verdict: str, path: Path) -> None:
    tree = etree.parse(str(path), _PARSER)
    assert _LIBXML2.validate(tree) is (verdict == "valid"), _LIBXML2.error_log
    assert _PURE.is_valid(str(path)) is (verdict == "valid")


@pytest.mark.parametrize("case", MESSAGES, ids=lambda c: c["name"])
def test_reader_agrees_with_the_vectors(case: dict[str, Any]) -> None:
    decode = DECODERS[case["type"]]
    if case["valid"]:
        decode(case["content"])
    else:
        with pytest.raises(ContentInvalidError):
            decode(case["content"])
    schema_valid = case.get("schema_valid", case["valid"])
    assert _PURE.is_valid(case["content"]) is schema_valid
    doc = etree.fromstring(case["content"].encode(), _PARSER)
    assert _LIBXML2.validate(doc) is schema_valid


@pytest.mark.parametrize("case", [c for c in MESSAGES if c["valid"]], ids=lambda c: c["name"])
def test_writers_reproduce_the_canonical_form(case: dict[str, Any]) -> None:
    encoders = {
        "WM.Report": wire.encode_report,
        "WM.Class": wire.encode_class,
        "WM.Plan": wire.encode_plan,
        "WM.Plan.Ack": wire.encode_ack,
        "WM.Plan.Cancel": wire.encode_cancel,
        "WM.Hello": wire.encode_hello,
    }
    value = DECODERS[case["type"]](case["content"])
    assert encoders[case["type"]](value) == case["content"]  # type: ignore[operator]


@pytest.mark.parametrize(
    "content",
    [
        "",
        "<wmreport",
        '<!DOCTYPE x [<!ENTITY a "b">]><wmreport robot="R" source="S"/>',
        '<wmhello robot="R" module="M" whiteboard="W"/>' * 2,
        "<wmplan>" + "<x>" * 100 + "</x>" * 100 + "</wmplan>",
    ],
)
def test_hostile_content_gets_an_error_of_the_table(content: str) -> None:
    for decode in DECODERS.values():
        with pytest.raises((ContentInvalidError, XmlForbiddenError, XmlTooDeepError)):
            decode(content)
