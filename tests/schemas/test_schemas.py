"""Validate the sample documents against the OpenAIR XSDs with two independent validators.

Every schema under schemas/ is compiled once per session with libxml2 (lxml) and with the pure
Python `xmlschema` package (XSD 1.0, which also checks Unique Particle Attribution). Each sample
under tests/schemas/docs/<schema>/{valid,invalid}/ must get the same verdict from both, and that
verdict must be its folder's.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import xmlschema
from lxml import etree

ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = ROOT / "schemas"
DOCS_DIR = Path(__file__).resolve().parent / "docs"
SCHEMA_NAMES = (
    "message",
    "content",
    "registration",
    "retrieve",
    "psyspec",
    "errors",
    "capabilities",
)
VERDICTS = ("valid", "invalid")
MIN_SAMPLES = 5  # per schema and verdict (task brief)


def safe_parser() -> etree.XMLParser:
    """Return a parser that never loads a DTD, expands entities or touches the network."""
    return etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)


@dataclass(frozen=True, slots=True, kw_only=True)
class SchemaPair:
    """One XSD compiled by both validators."""

    name: str
    libxml2: etree.XMLSchema
    pure: Any  # xmlschema.XMLSchema10 (the package ships no type information)

    def verdicts(self, tree: etree._ElementTree) -> tuple[bool, bool, str]:
        """Return (libxml2 verdict, xmlschema verdict, the first error of each, for messages)."""
        ok_libxml2 = self.libxml2.validate(tree)
        first_pure = next(iter(self.pure.iter_errors(tree)), None)
        libxml2_error = str(self.libxml2.error_log).split("\n", 1)[0]
        pure_error = "" if first_pure is None else str(first_pure.reason)
        errors = f"libxml2: {libxml2_error!r}; xmlschema: {pure_error!r}"
        return ok_libxml2, first_pure is None, errors


@dataclass(slots=True)
class SchemaCache:
    """Compile each schema at most once per test session, on first use."""

    compiled: dict[str, SchemaPair] = field(default_factory=dict)

    def __getitem__(self, name: str) -> SchemaPair:
        if name not in self.compiled:
            path = SCHEMA_DIR / f"{name}.xsd"
            self.compiled[name] = SchemaPair(
                name=name,
                libxml2=etree.XMLSchema(etree.parse(str(path), safe_parser())),
                pure=xmlschema.XMLSchema10(str(path)),
            )
        return self.compiled[name]


@pytest.fixture(scope="session")
def schemas() -> SchemaCache:
    """Return the session-wide cache of compiled schemas."""
    return SchemaCache()


def sample_paths() -> Iterator[tuple[str, str, Path]]:
    """Yield (schema, verdict, path) for every sample document."""
    for name in SCHEMA_NAMES:
        for verdict in VERDICTS:
            for path in sorted((DOCS_DIR / name / verdict).glob("*.xml")):
                yield name, verdict, path


SAMPLES = list(sample_paths())


@pytest.mark.parametrize("name", SCHEMA_NAMES)
def test_schema_compiles_with_both_validators(schemas: SchemaCache, name: str) -> None:
    pair = schemas[name]
    # Both compilers refuse a non-deterministic content model (XSD 1.0 UPA) with an exception,
    # so reaching this point means the schema is a correct XSD 1.0 schema for both.
    assert pair.pure.XSD_VERSION == "1.0"
    assert pair.pure.validation == "strict"


# The envelope with an optional known slot after content: <extensions> could match both the
# element particle and the other-slots wildcard, which XSD 1.0 forbids (UPA).
NON_DETERMINISTIC = b"""<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema">
  <xs:element name="message"><xs:complexType><xs:sequence>
    <xs:element name="content" type="xs:string"/>
    <xs:element name="extensions" type="xs:string" minOccurs="0"/>
    <xs:any processContents="lax" minOccurs="0" maxOccurs="unbounded"/>
  </xs:sequence></xs:complexType></xs:element>
</xs:schema>"""


def test_both_validators_enforce_unique_particle_attribution() -> None:
    # Guards the meaning of the compile test above: a UPA violation is a compile error for both.
    with pytest.raises(etree.XMLSchemaParseError, match="not determinist"):
        etree.XMLSchema(etree.fromstring(NON_DETERMINISTIC, safe_parser()))
    with pytest.raises(xmlschema.XMLSchemaModelError, match="Unique Particle Attribution"):
        xmlschema.XMLSchema10(NON_DETERMINISTIC.decode())


@pytest.mark.parametrize(
    ("name", "verdict", "path"),
    SAMPLES,
    ids=[f"{n}/{v}/{p.name}" for n, v, p in SAMPLES],
)
def test_sample_verdict_matches_folder(
    schemas: SchemaCache, name: str, verdict: str, path: Path
) -> None:
    tree = etree.parse(str(path), safe_parser())
    ok_libxml2, ok_pure, errors = schemas[name].verdicts(tree)
    assert ok_libxml2 == ok_pure, f"the validators disagree on {path.name}: {errors}"
    assert ok_libxml2 == (verdict == "valid"), f"{path.name} should be {verdict}: {errors}"


@pytest.mark.parametrize("name", SCHEMA_NAMES)
@pytest.mark.parametrize("verdict", VERDICTS)
def test_each_schema_has_enough_samples(name: str, verdict: str) -> None:
    found = [p for n, v, p in SAMPLES if (n, v) == (name, verdict)]
    assert len(found) >= MIN_SAMPLES, f"{name}/{verdict} has {len(found)} samples"


def leading_comments(path: Path) -> list[str]:
    """Return the text of the comments before the root element of `path`."""
    tree = etree.parse(str(path), safe_parser())
    comments: list[str] = []
    node = tree.getroot().getprevious()
    while node is not None:
        if isinstance(node, etree._Comment):
            comments.insert(0, str(node.text).strip())
        node = node.getprevious()
    return comments


@pytest.mark.parametrize(
    ("name", "verdict", "path"),
    SAMPLES,
    ids=[f"{n}/{v}/{p.name}" for n, v, p in SAMPLES],
)
def test_sample_says_where_it_comes_from_and_why(name: str, verdict: str, path: Path) -> None:
    comments = leading_comments(path)
    assert any(re.match(r"Source: \S", c) for c in comments), f"{path.name}: no Source comment"
    if verdict == "invalid":
        assert any(re.match(r"Invalid: \S", c) for c in comments), f"{path.name}: no reason"


def test_error_table_is_valid(schemas: SchemaCache) -> None:
    tree = etree.parse(str(ROOT / "spec" / "errors.xml"), safe_parser())
    ok_libxml2, ok_pure, errors = schemas["errors"].verdicts(tree)
    assert (ok_libxml2, ok_pure) == (True, True), errors
