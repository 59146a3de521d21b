"""House rules of the OpenAIR XSDs, and the type and pattern regexes against the spec's prose.

Static rules (style.md, "XSD and the spec"): XSD 1.0 only, no target namespace, named global
`...Type` definitions with documentation, relative includes, and requirement IDs that exist in
spec/requirements.xml. Property tests: the XSD regexes of TypeNameType and PatternType accept
exactly what spec 5.1 / 5.2 (OA-TYPE-1, OA-MATCH-7) define, checked with both validators.
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path
from typing import Any

import pytest
import xmlschema
from hypothesis import example, given
from hypothesis import strategies as st
from lxml import etree

ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = ROOT / "schemas"
XS = "http://www.w3.org/2001/XMLSchema"
OWNED = ("message", "content", "registration", "retrieve", "psyspec", "errors", "capabilities")
XSD11_ONLY = {"assert", "assertion", "alternative", "openContent", "defaultOpenContent", "override"}
VC = "http://www.w3.org/2007/XMLSchema-versioning"  # XSD 1.1 conditional inclusion
REQUIREMENT_ID = re.compile(r"\bOA-[A-Z]+-[0-9]+\b")


def parse(path: Path) -> etree._ElementTree:
    """Parse `path` without DTDs, entities or network access."""
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    return etree.parse(str(path), parser)


def xs(local: str) -> str:
    """Return the Clark name of an element of the XML Schema namespace."""
    return f"{{{XS}}}{local}"


@pytest.mark.parametrize("name", OWNED)
def test_schema_is_plain_xsd_1_0_without_namespace(name: str) -> None:
    root = parse(SCHEMA_DIR / f"{name}.xsd").getroot()
    assert root.tag == xs("schema")
    assert root.get("targetNamespace") is None  # OpenAIR XML is in no namespace
    used = {etree.QName(e).localname for e in root.iter() if isinstance(e.tag, str)}
    assert used.isdisjoint(XSD11_ONLY)
    elements = [e for e in root.iter() if isinstance(e.tag, str)]
    assert not [a for e in elements for a in e.attrib if etree.QName(a).namespace == VC]


@pytest.mark.parametrize("name", OWNED)
def test_types_are_named_and_documented(name: str) -> None:
    root = parse(SCHEMA_DIR / f"{name}.xsd").getroot()
    for kind in ("complexType", "simpleType"):
        for node in root.iter(xs(kind)):
            type_name = node.get("name")
            line = node.sourceline
            assert type_name is not None, f"{name}.xsd:{line}: anonymous {kind}"
            assert type_name.endswith("Type"), f"{name}.xsd:{line}: {type_name}"
            assert node.getparent() is root, f"{name}.xsd:{line}: {type_name} is not global"
            text = node.findtext(f"{xs('annotation')}/{xs('documentation')}") or ""
            assert text.strip(), f"{name}.xsd:{line}: {type_name} has no documentation"


@pytest.mark.parametrize("name", OWNED)
def test_includes_are_relative_and_exist(name: str) -> None:
    root = parse(SCHEMA_DIR / f"{name}.xsd").getroot()
    assert root.find(xs("import")) is None  # one (empty) namespace: include, never import
    for node in root.iter(xs("include")):
        location = node.get("schemaLocation", "")
        assert "/" not in location and ":" not in location, location
        assert (SCHEMA_DIR / location).is_file(), location


@cache
def known_requirement_ids() -> frozenset[str]:
    """Return the requirement IDs of the generated catalogue."""
    tree = parse(ROOT / "spec" / "requirements.xml")
    return frozenset(str(e.get("id")) for e in tree.getroot().iter("requirement"))


@pytest.mark.parametrize("name", OWNED)
def test_cited_requirements_exist(name: str) -> None:
    text = (SCHEMA_DIR / f"{name}.xsd").read_text(encoding="utf-8")
    cited = set(REQUIREMENT_ID.findall(text))
    assert cited, f"{name}.xsd cites no requirement"
    assert cited <= known_requirement_ids(), sorted(cited - known_requirement_ids())


# --- TypeNameType and PatternType against the prose of spec 5.1 / 5.2 ----------------------------

# Spec 5.1 (OA-TYPE-5): a segment character is any character except '.', '*' and those of the
# table of Unicode 14.0.0 categories, read here from the shared vector file the spec names.
EXCLUDED_RANGES = tuple(
    (int(r["first"][2:], 16), int(r["last"][2:], 16))
    for r in json.loads(
        (ROOT / "spec" / "vectors" / "unicode" / "segment-exclusions.json").read_text("utf-8")
    )["ranges"]
)


def is_segment_char(c: str) -> bool:
    """Return whether spec 5.1 allows `c` inside a segment."""
    code = ord(c)
    return c not in ".*" and not any(a <= code <= b for a, b in EXCLUDED_RANGES)


def prose_type_ok(text: str) -> bool:
    """OA-TYPE-1: non-empty segments of segment characters separated by single dots."""
    return all(seg and all(is_segment_char(c) for c in seg) for seg in text.split("."))


def prose_pattern_ok(text: str) -> bool:
    """OA-MATCH-7: as a type, but '*' may occur in a segment, never twice in a row."""
    return all(
        seg and "**" not in seg and all(c == "*" or is_segment_char(c) for c in seg)
        for seg in text.split(".")
    )


@cache
def content_schemas() -> tuple[etree.XMLSchema, Any]:
    """Return content.xsd compiled by both validators (phase and trigger are declared there)."""
    path = SCHEMA_DIR / "content.xsd"
    return etree.XMLSchema(parse(path)), xmlschema.XMLSchema10(str(path))


def xsd_verdicts(element: etree._Element) -> tuple[bool, bool]:
    """Return whether libxml2 and xmlschema find `element` valid against content.xsd."""
    libxml2, pure = content_schemas()
    return libxml2.validate(element.getroottree()), bool(pure.is_valid(element))


EDGE_CHARS = list(".**:?[]aZ9é\t\r\n \u0085\u00a0\u1680\u2000\u200a\u200b\u2028\u202f\u3000")
EDGE_CHARS += ["\u007f", "\u009f", "\u00ad", "\ue000", "\ufffd", "\U0001f600"]
# Characters XML 1.0 can carry (an attribute value cannot hold the others at all).
NOT_XML = "".join(chr(c) for c in range(0x20) if c not in (0x9, 0xA, 0xD)) + "\ufffe\uffff"
XML_CHARS = st.characters(exclude_categories=["Cs"], exclude_characters=NOT_XML)
CANDIDATES = st.text(alphabet=st.one_of(st.sampled_from(EDGE_CHARS), XML_CHARS), max_size=12)


@given(CANDIDATES)
@example("Psyclone.Context:SoB.Alive.Awake")
@example("Test.Ping.[AB]")
@example("Test..Ping")
@example("Test.Ping\u200b")
def test_type_regex_is_the_prose_rule(text: str) -> None:
    element = etree.Element("phase", context=text)
    assert xsd_verdicts(element) == (prose_type_ok(text),) * 2


@given(CANDIDATES)
@example("*")
@example("*.*")
@example("A*B*C.*x")
@example("Test.**")
@example("Test.*.")
def test_pattern_regex_is_the_prose_rule(text: str) -> None:
    element = etree.Element("trigger", type=text)
    assert xsd_verdicts(element) == (prose_pattern_ok(text),) * 2
