"""schemas/ontology.xsd: valid with two independent validators, and the examples valid against it.

Like tests/schemas, the schema is compiled with libxml2 (lxml) and with the pure Python
`xmlschema` package (XSD 1.0, Unique Particle Attribution checked); every document below must get
the same verdict from both.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import xmlschema
from lxml import etree
from ontology_helpers import FIXTURES, ONTOLOGY, ROOT

from openair_ontology.history import read_xml
from openair_ontology.infer import infer_ontology
from openair_ontology.parse import encode_ontology

XSD = ROOT / "schemas" / "ontology.xsd"


def _parser() -> etree.XMLParser:
    return etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)


@pytest.fixture(scope="module")
def validators() -> tuple[etree.XMLSchema, Any]:
    return (
        etree.XMLSchema(etree.parse(str(XSD), _parser())),
        xmlschema.XMLSchema10(str(XSD)),
    )


def _verdicts(validators: tuple[etree.XMLSchema, Any], data: bytes) -> tuple[bool, bool]:
    libxml2, pure = validators
    tree = etree.ElementTree(etree.fromstring(data, _parser()))
    return libxml2.validate(tree), next(iter(pure.iter_errors(tree)), None) is None


def test_schema_is_xsd_1_0(validators: tuple[etree.XMLSchema, Any]) -> None:
    assert validators[1].XSD_VERSION == "1.0"


@pytest.mark.parametrize(
    "path",
    [ONTOLOGY, FIXTURES / "dangling.ontology.xml"],
    ids=lambda p: Path(p).name,
)
def test_shipped_ontologies_are_valid(validators: tuple[etree.XMLSchema, Any], path: Path) -> None:
    assert _verdicts(validators, path.read_bytes()) == (True, True)


def test_inferred_ontology_is_valid(validators: tuple[etree.XMLSchema, Any]) -> None:
    history = read_xml(ROOT / "examples" / "seed-paper.history.xml")
    onto, _ = infer_ontology(history.messages, name="inferred")
    assert _verdicts(validators, encode_ontology(onto)) == (True, True)


INVALID = {
    "segment with a dot": b'<ontology name="x"><type segment="A.B"/></ontology>',
    "segment with a star": b'<ontology name="x"><type segment="A*"/></ontology>',
    "segment with a space": b'<ontology name="x"><type segment="A B"/></ontology>',
    "empty segment": b'<ontology name="x"><type segment=""/></ontology>',
    "no segment": b'<ontology name="x"><type/></ontology>',
    "no name": b'<ontology><type segment="A"/></ontology>',
    "unknown kind": b'<ontology name="x"><type segment="A" kind="thing"/></ontology>',
    "bad separator": (
        b'<ontology name="x"><type segment="A" parameter="p" separator="/"/></ontology>'
    ),
    "children out of order": (
        b'<ontology name="x"><type segment="A"><example/><description>d</description></type>'
        b"</ontology>"
    ),
    "namespace after types": (
        b'<ontology name="x"><type segment="A"/><namespace prefix="A"/></ontology>'
    ),
    "replacedBy not a type": (
        b'<ontology name="x"><type segment="A"><deprecated replacedBy="A..B"/></type></ontology>'
    ),
    "negative count": (
        b'<ontology name="x"><type segment="A"><observed count="-1"/></type></ontology>'
    ),
    "first not a dateTime": (
        b'<ontology name="x"><type segment="A"><observed count="1" first="yesterday"/></type>'
        b"</ontology>"
    ),
    "poster without module": b'<ontology name="x"><type segment="A"><poster/></type></ontology>',
    "wrong format": b'<ontology name="x" format="2.0"/>',
    "unknown element": b'<ontology name="x"><types/></ontology>',
}

VALID = {
    "minimal": b'<ontology name="x"/>',
    "colon segment": b'<ontology name="x"><type segment="Context:A"/></ontology>',
    "family": (
        b'<ontology name="x"><type segment="Lost" parameter="module" separator="."/></ontology>'
    ),
    "example with xml": (
        b'<ontology name="x"><type segment="A"><example from="M" to="WB">'
        b'<dictionary><entry name="k">v</entry></dictionary></example></type></ontology>'
    ),
    "every child in order": (
        b'<ontology name="x" version="1" format="1.0"><description>d</description>'
        b'<namespace prefix="A" owner="o" version="1" url="http://example.org/"/>'
        b'<type segment="A" kind="message"><description>d</description>'
        b'<content language="xml" root="dictionary" schema="s.xsd">c</content>'
        b'<deprecated replacedBy="A.B" since="2">r</deprecated><example>text</example>'
        b'<poster module="P" whiteboard="WB1"/><subscriber module="S"/>'
        b'<observed count="3" first="2026-11-22T10:00:00.000Z" last="2026-11-22T10:00:01Z" '
        b'whiteboards="WB1 WB2"/><type segment="B" kind="stream"/></type></ontology>'
    ),
}


@pytest.mark.parametrize("name", sorted(INVALID))
def test_invalid_documents_are_refused_by_both(
    validators: tuple[etree.XMLSchema, Any], name: str
) -> None:
    assert _verdicts(validators, INVALID[name]) == (False, False)


@pytest.mark.parametrize("name", sorted(VALID))
def test_valid_documents_are_accepted_by_both(
    validators: tuple[etree.XMLSchema, Any], name: str
) -> None:
    assert _verdicts(validators, VALID[name]) == (True, True)
