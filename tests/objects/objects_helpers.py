"""Shared helpers for the content-object tests: sample documents and the compiled XSDs."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from lxml import etree

from openair.protocol.xmlsafe import parse_fragment, parse_xml

ROOT = Path(__file__).resolve().parents[2]
SCHEMA_DIR = ROOT / "schemas"
DOCS_DIR = ROOT / "tests" / "schemas" / "docs"


def doc_paths(schema: str, verdict: str) -> list[Path]:
    """Return the sample documents of tests/schemas/docs/<schema>/<verdict>/, sorted."""
    return sorted((DOCS_DIR / schema / verdict).glob("*.xml"))


def doc_content(path: Path) -> str:
    """Return a sample as message content: its root, or the children of `<registration>`.

    The synthetic `<registration>` container (schemas/registration.xsd) only exists so the
    schema can check a two-root bare form; on the wire the content is its children.
    """
    root = parse_xml(path.read_bytes())
    if root.tag == "registration":
        return "".join(etree.tostring(child, encoding="unicode", with_tail=False) for child in root)
    return etree.tostring(root, encoding="unicode", with_tail=False)


@cache
def content_schema() -> etree.XMLSchema:
    """Compile schemas/content.xsd, which includes every wire schema (schemas/README.md)."""
    return etree.XMLSchema(etree.parse(str(SCHEMA_DIR / "content.xsd")))


@cache
def capabilities_schema() -> etree.XMLSchema:
    """Compile the stand-alone schemas/capabilities.xsd."""
    return etree.XMLSchema(etree.parse(str(SCHEMA_DIR / "capabilities.xsd")))


def schema_errors(schema: etree.XMLSchema, xml: str, root: str) -> str:
    """Validate one document; return "" when valid, else the reasons.

    Every global element of the include set is a valid document root (schemas/README.md), so
    the root's name is checked here as well.
    """
    el = parse_xml(xml.encode("utf-8"))
    if el.tag != root:
        return f"root is <{el.tag}>, expected <{root}>"
    if schema.validate(el):
        return ""
    return str(schema.error_log)


def registration_errors(content: str) -> str:
    """Validate AIR.Subscribe content inside the synthetic `<registration>` container."""
    container = etree.Element("registration")
    container.extend(parse_fragment(content))
    xml = etree.tostring(container, encoding="unicode")
    return schema_errors(content_schema(), xml, "registration")
