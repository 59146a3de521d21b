"""Read and write ontology files (schemas/ontology.xsd).

`read_ontology` parses with the hardened parser (`openair.protocol.xmlsafe.parse_xml`: no DTD, no
entities, no network, OA-SEC-1/2), validates against `ontology.xsd`, then checks what the schema
cannot say: sibling segments unique ignoring ASCII case (OA-MATCH-1), every full name a valid
type within the OA-TYPE-4 limits, unique namespace prefixes, no children under a parameterised
type. Every problem is an `OntologyError` whose text is `source:line: message`.

`encode_ontology` writes an `Ontology` back as indented XML that `read_ontology` reads to an
equal value (examples' XML content is re-indented on reading, so it survives the round trip).
"""

from __future__ import annotations

import textwrap
from copy import deepcopy
from functools import lru_cache
from pathlib import Path
from typing import Any

from lxml import etree

from openair.protocol.errors import OpenAIRError
from openair.protocol.matching import ascii_fold
from openair.protocol.types import validate_type
from openair.protocol.xmlsafe import XmlLimits, parse_fragment, parse_xml
from openair.resources import schema_path
from openair_ontology.model import (
    ContentSpec,
    Deprecation,
    Example,
    Kind,
    Link,
    Namespace,
    Observed,
    Ontology,
    TypeNode,
)

__all__ = [
    "FORMAT_VERSION",
    "OntologyError",
    "encode_ontology",
    "indent_xml",
    "parse_ontology",
    "read_ontology",
]

FORMAT_VERSION = "1.0"
MAX_ONTOLOGY_BYTES = 64 * 1024 * 1024  # far above any hand-written file; bounds hostile input
MAX_DEPTH = 80  # 32 type segments (OA-TYPE-4) nest 32 <type> elements, plus example content


class OntologyError(ValueError):
    """An ontology file that cannot be read: `source:line: message`."""


@lru_cache(maxsize=1)
def _schema() -> etree.XMLSchema:
    """Load schemas/ontology.xsd (a trusted, shipped file)."""
    return etree.XMLSchema(etree.parse(str(schema_path("ontology.xsd"))))


def read_ontology(path: str | Path) -> Ontology:
    """Read, validate and return the ontology file at `path`; raise OntologyError."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise OntologyError(f"{path}:0: cannot read the ontology: {exc.strerror}") from None
    return parse_ontology(data, source=str(path))


def parse_ontology(data: bytes, *, source: str = "<ontology>") -> Ontology:
    """Parse and validate ontology bytes; errors name `source` and the line."""
    try:
        root = parse_xml(data, XmlLimits(max_bytes=MAX_ONTOLOGY_BYTES, max_depth=MAX_DEPTH))
    except OpenAIRError as exc:
        raise OntologyError(f"{source}:1: {exc}") from None
    if root.tag != "ontology":
        raise OntologyError(
            f"{source}:{root.sourceline}: the root must be ontology, not {root.tag}"
        )
    schema = _schema()
    if not schema.validate(root):
        log: Any = schema.error_log  # the stubs declare _ErrorLog empty
        raise OntologyError(f"{source}:{log[0].line}: {log[0].message}")
    return _Reader(source).ontology(root)


def _children(el: etree._Element, tag: str) -> list[etree._Element]:
    return [c for c in el if c.tag == tag]


def _child(el: etree._Element, tag: str) -> etree._Element | None:
    return next((c for c in el if c.tag == tag), None)


def _text(el: etree._Element | None) -> str:
    """Return an element's text with common indentation removed and outer blank space trimmed."""
    if el is None or el.text is None:
        return ""
    return textwrap.dedent(el.text).strip()


class _Reader:
    """Builds the values and checks the rules the schema cannot express."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, el: etree._Element, message: str) -> OntologyError:
        return OntologyError(f"{self.source}:{el.sourceline}: {message}")

    def ontology(self, root: etree._Element) -> Ontology:
        namespaces = tuple(self.namespace(el) for el in _children(root, "namespace"))
        seen: set[str] = set()
        for el, ns in zip(_children(root, "namespace"), namespaces, strict=True):
            if ascii_fold(ns.prefix) in seen:
                raise self.fail(el, f"namespace {ns.prefix!r} is declared twice")
            seen.add(ascii_fold(ns.prefix))
        return Ontology(
            name=root.get("name", ""),
            version=root.get("version", ""),
            description=_text(_child(root, "description")),
            namespaces=namespaces,
            types=self.nodes(root, ""),
        )

    def namespace(self, el: etree._Element) -> Namespace:
        return Namespace(
            prefix=el.get("prefix", ""),
            owner=el.get("owner", ""),
            version=el.get("version", ""),
            url=el.get("url", ""),
            description=_text(_child(el, "description")),
        )

    def nodes(self, parent: etree._Element, parent_name: str) -> tuple[TypeNode, ...]:
        """Read the `<type>` children of `parent`; sibling segments are unique (OA-MATCH-1)."""
        nodes: list[TypeNode] = []
        seen: set[str] = set()
        for el in _children(parent, "type"):
            node = self.node(el, parent_name)
            if ascii_fold(node.segment) in seen:
                name = f"{parent_name}.{node.segment}" if parent_name else node.segment
                raise self.fail(el, f"type {name!r} is defined twice (case is ignored)")
            seen.add(ascii_fold(node.segment))
            nodes.append(node)
        return tuple(nodes)

    def node(self, el: etree._Element, parent_name: str) -> TypeNode:
        segment = el.get("segment", "")
        name = f"{parent_name}.{segment}" if parent_name else segment
        try:
            validate_type(name)  # OA-TYPE-1, OA-TYPE-4
        except OpenAIRError as exc:
            raise self.fail(el, exc.detail) from None
        children = self.nodes(el, name)
        if el.get("parameter") and children:
            raise self.fail(el, f"type {name!r} has a parameter and child types")
        kind = el.get("kind")
        return TypeNode(
            segment=segment,
            kind=Kind(kind) if kind else None,
            description=_text(_child(el, "description")),
            content=_content(_child(el, "content")),
            deprecated=_deprecation(_child(el, "deprecated")),
            examples=tuple(_example(x) for x in _children(el, "example")),
            posters=tuple(_link(x) for x in _children(el, "poster")),
            subscribers=tuple(_link(x) for x in _children(el, "subscriber")),
            observed=_observed(_child(el, "observed")),
            parameter=el.get("parameter", ""),
            separator=el.get("separator", "."),
            children=children,
        )


def _content(el: etree._Element | None) -> ContentSpec | None:
    if el is None:
        return None
    return ContentSpec(
        language=el.get("language", ""),
        root=el.get("root", ""),
        schema=el.get("schema", ""),
        description=_text(el),
    )


def _deprecation(el: etree._Element | None) -> Deprecation | None:
    if el is None:
        return None
    return Deprecation(
        replaced_by=el.get("replacedBy", ""), since=el.get("since", ""), reason=_text(el)
    )


def _link(el: etree._Element) -> Link:
    return Link(module=el.get("module", ""), whiteboard=el.get("whiteboard", ""))


def _observed(el: etree._Element | None) -> Observed | None:
    if el is None:
        return None
    return Observed(
        count=int(el.get("count", "0")),
        first=el.get("first", ""),
        last=el.get("last", ""),
        whiteboards=tuple(el.get("whiteboards", "").split()),
    )


def _indented(el: etree._Element) -> str:
    """Serialize a copy of `el` re-indented by two spaces (whitespace-only text dropped)."""
    copy = deepcopy(el)  # no second parse; text beside the element (its tail) is not shown
    copy.tail = None
    for node in copy.iter():
        if node.text is not None and not node.text.strip():
            node.text = None
        if node.tail is not None and not node.tail.strip():
            node.tail = None
    etree.indent(copy, space="  ")
    return etree.tostring(copy, encoding="unicode", with_tail=False)


def indent_xml(content: str) -> str:
    """Return XML content (zero or more elements) re-indented; raise OpenAIRError if not XML."""
    return "\n".join(_indented(el) for el in parse_fragment(content))


def _example(el: etree._Element) -> Example:
    """Read `<example>`: elements inside make XML content, otherwise the text is the content."""
    elements = [c for c in el if isinstance(c.tag, str)]
    content = "\n".join(_indented(c) for c in elements) if elements else _text(el)
    language = el.get("language", "xml" if elements else "")
    return Example(
        title=el.get("title", ""),
        sender=el.get("from", ""),
        to=el.get("to", ""),
        language=language,
        content=content,
        is_xml=bool(elements),
    )


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------


def _sub(parent: etree._Element, tag: str, text: str = "", **attrs: str) -> etree._Element:
    """Append `<tag attrs>text</tag>`, leaving out empty attributes."""
    el = etree.SubElement(parent, tag, {k: v for k, v in attrs.items() if v})
    if text:
        el.text = text
    return el


def encode_ontology(ontology: Ontology) -> bytes:
    """Write `ontology` as indented UTF-8 XML with an XML declaration."""
    root = etree.Element("ontology", {"name": ontology.name})
    if ontology.version:
        root.set("version", ontology.version)
    root.set("format", FORMAT_VERSION)
    if ontology.description:
        _sub(root, "description", ontology.description)
    for ns in ontology.namespaces:
        el = _sub(root, "namespace", prefix=ns.prefix, owner=ns.owner, version=ns.version)
        if ns.url:
            el.set("url", ns.url)
        if ns.description:
            _sub(el, "description", ns.description)
    for node in ontology.types:
        _write_node(root, node)
    etree.indent(root, space="  ")
    return etree.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def _write_node(parent: etree._Element, node: TypeNode) -> None:
    el = _sub(parent, "type", segment=node.segment, kind=node.kind.value if node.kind else "")
    if node.parameter:
        el.set("parameter", node.parameter)
        if node.separator != ".":
            el.set("separator", node.separator)
    if node.description:
        _sub(el, "description", node.description)
    if node.content is not None:
        c = node.content
        _sub(el, "content", c.description, language=c.language, root=c.root, schema=c.schema)
    if node.deprecated is not None:
        d = node.deprecated
        _sub(el, "deprecated", d.reason, replacedBy=d.replaced_by, since=d.since)
    for example in node.examples:
        _write_example(el, example)
    for tag, links in (("poster", node.posters), ("subscriber", node.subscribers)):
        for link in links:
            _sub(el, tag, module=link.module, whiteboard=link.whiteboard)
    if node.observed is not None:
        o = node.observed
        _sub(
            el,
            "observed",
            count=str(o.count),
            first=o.first,
            last=o.last,
            whiteboards=" ".join(o.whiteboards),
        )
    for child in node.children:
        _write_node(el, child)


def _write_example(parent: etree._Element, example: Example) -> None:
    el = _sub(
        parent,
        "example",
        title=example.title,
        **{"from": example.sender},
        to=example.to,
        language=example.language,
    )
    if not example.is_xml:
        el.text = example.content
        return
    try:
        el.extend(parse_fragment(example.content))
    except OpenAIRError:  # content that is not XML after all: keep it as text
        el.text = example.content
