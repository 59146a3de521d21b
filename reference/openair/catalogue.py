"""Extract the OpenAIR requirements from the spec prose and read the generated catalogue.

The normative text is `spec/openair-1.0.md`. A requirement is a paragraph (or list item) that
starts with its identifier in bold, `**OA-GROUP-N**`, followed by text holding at least one
RFC 2119 key word in capitals; the first key word gives its level (section 1.1 of the spec). The
section is the number of the nearest enclosing numbered heading. A requirement that belongs to an
extension says so with "(extension `name`)".

`tools/gen_catalogue.py` writes the extraction to `spec/requirements.xml`; `load_catalogue` reads
that file back (the conformance suite uses it to quote requirement sentences).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

__all__ = [
    "DEFAULT_CATALOGUE",
    "DEFAULT_SPEC",
    "ID_PATTERN",
    "LEVELS",
    "CatalogueError",
    "Requirement",
    "cited_ids",
    "extract_requirements",
    "find_stray_keywords",
    "load_catalogue",
    "render_catalogue",
]

_DATA = Path(__file__).parent / "_data" / "spec"
DEFAULT_CATALOGUE = _DATA / "requirements.xml"
DEFAULT_SPEC = _DATA / "openair-1.0.md"

LEVELS = ("MUST", "SHOULD", "MAY")
ID_PATTERN = r"OA-[A-Z]+-[0-9]+"

_ID_RE = re.compile(rf"^{ID_PATTERN}$")
_CITED_RE = re.compile(rf"(?<![A-Za-z0-9-]){ID_PATTERN}(?![0-9])")
_SECTION_RE = re.compile(r"^[0-9]+(\.[0-9]+)*$")
_EXTENSION_RE = re.compile(r"^[a-z][a-z0-9]*(-[a-z0-9]+)*$")
# Longer key words first, so that "MUST NOT" is not read as "MUST" (the level is the same anyway,
# but the keyword reported in lint messages should be the whole one).
_KEYWORD_RE = re.compile(
    r"\b(MUST NOT|MUST|REQUIRED|SHALL NOT|SHALL|SHOULD NOT|SHOULD|NOT RECOMMENDED|"
    r"RECOMMENDED|MAY|OPTIONAL)\b"
)
_KEYWORD_LEVEL = {
    "MUST NOT": "MUST",
    "MUST": "MUST",
    "REQUIRED": "MUST",
    "SHALL NOT": "MUST",
    "SHALL": "MUST",
    "SHOULD NOT": "SHOULD",
    "SHOULD": "SHOULD",
    "NOT RECOMMENDED": "SHOULD",
    "RECOMMENDED": "SHOULD",
    "MAY": "MAY",
    "OPTIONAL": "MAY",
}
_HEADING_RE = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
_NUMBERED_RE = re.compile(r"^([0-9]+(?:\.[0-9]+)*)\.?(?:\s|$)")
_FENCE_RE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
_LIST_ITEM_RE = re.compile(r"^\s*(?:[-*+]|[0-9]+[.)])\s+")
_REQ_START_RE = re.compile(rf"^\*\*({ID_PATTERN})\*\*\s+(\S.*)$", re.DOTALL)
_EXT_MARK_RE = re.compile(r"\(extension `([^`]*)`\)")
_CODE_SPAN_RE = re.compile(r"(`+)(.+?)\1", re.DOTALL)
_QUOTED_RE = re.compile(r"\"[^\"]*\"|“[^”]*”")
_ESCAPE_RE = re.compile(r"\\([\\`*_{}\[\]()#+\-.!|<>\"])")
_LINK_RE = re.compile(r"\[([^\]]+)\]\([^)]*\)")
_STRONG_RE = re.compile(r"\*\*(.+?)\*\*|__(.+?)__", re.DOTALL)
_EMPH_RE = re.compile(r"(?<![\w*])\*(?![\s*])(.+?)(?<![\s*])\*(?![\w*])", re.DOTALL)

XSI = "http://www.w3.org/2001/XMLSchema-instance"
_HEADER = (
    b'<?xml version="1.0" encoding="UTF-8"?>\n'
    b"<!-- Generated from spec/openair-1.0.md by tools/gen_catalogue.py; do not edit. -->\n"
)


class CatalogueError(ValueError):
    """The spec prose or the catalogue file breaks the requirement format."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Requirement:
    """One requirement: its ID, level, section, plain-text sentence and extension (if any)."""

    id: str
    level: str
    section: str
    text: str
    extension: str | None = None

    def __post_init__(self) -> None:
        if not _ID_RE.match(self.id):
            raise CatalogueError(f"invalid requirement id {self.id!r}")
        if self.level not in LEVELS:
            raise CatalogueError(f"{self.id}: invalid level {self.level!r}")
        if not _SECTION_RE.match(self.section):
            raise CatalogueError(f"{self.id}: invalid section {self.section!r}")
        if not self.text.strip():
            raise CatalogueError(f"{self.id}: empty text")
        if self.extension is not None and not _EXTENSION_RE.match(self.extension):
            raise CatalogueError(f"{self.id}: invalid extension name {self.extension!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class _Block:
    """A paragraph or list item of the prose, outside code fences."""

    line: int  # 1-based number of its first line
    section: str | None
    raw: str  # the lines joined with spaces, list marker removed


def _blocks(markdown: str) -> Iterator[_Block]:
    """Split Markdown into paragraphs and list items, tracking the numbered section."""
    section: str | None = None
    fence: str | None = None
    lines: list[str] = []
    start = 0

    def flush() -> Iterator[_Block]:
        if lines:
            yield _Block(line=start, section=section, raw=" ".join(s.strip() for s in lines))
            lines.clear()

    for number, line in enumerate(markdown.splitlines(), start=1):
        fence_match = _FENCE_RE.match(line)
        if fence is not None:
            # A fence closes only with the same character, at least as long (CommonMark).
            closer = fence_match.group(1) if fence_match else ""
            if closer[:1] == fence[0] and len(closer) >= len(fence):
                fence = None
            continue
        if fence_match:
            yield from flush()
            fence = fence_match.group(1)
            continue
        heading = _HEADING_RE.match(line)
        if heading:
            yield from flush()
            numbered = _NUMBERED_RE.match(heading.group(2))
            if numbered:
                section = numbered.group(1)
            elif len(heading.group(1)) <= 2:
                # An unnumbered top-level heading (revision history, appendices) ends the
                # numbered part it follows: nothing after it belongs to that section.
                section = None
            continue
        if not line.strip():
            yield from flush()
            continue
        item = _LIST_ITEM_RE.match(line)
        if item:
            yield from flush()
            line = line[item.end() :]
        if not lines:
            start = number
        lines.append(line)
    yield from flush()


def _split_code(text: str) -> list[tuple[bool, str]]:
    """Split inline Markdown into (is_code, text) parts."""
    parts: list[tuple[bool, str]] = []
    pos = 0
    for match in _CODE_SPAN_RE.finditer(text):
        parts.append((False, text[pos : match.start()]))
        code = match.group(2)
        # CommonMark strips one space on each side of a code span that has both.
        if len(code) > 2 and code.startswith(" ") and code.endswith(" ") and code.strip():
            code = code[1:-1]
        parts.append((True, code))
        pos = match.end()
    parts.append((False, text[pos:]))
    return parts


def _plain_prose(text: str) -> str:
    """Strip emphasis, links and escapes from prose that holds no code span."""
    escapes: list[str] = []

    def protect(match: re.Match[str]) -> str:
        escapes.append(match.group(1))
        return f"\ue000{len(escapes) - 1}\ue001"

    text = _ESCAPE_RE.sub(protect, text)
    text = _LINK_RE.sub(r"\1", text)
    text = _STRONG_RE.sub(lambda m: m.group(1) or m.group(2), text)
    text = _EMPH_RE.sub(r"\1", text)
    return re.sub("\ue000([0-9]+)\ue001", lambda m: escapes[int(m.group(1))], text)


def _plain_text(markdown: str) -> str:
    """Render inline Markdown as plain text (code spans keep their content verbatim)."""
    out = "".join(part if code else _plain_prose(part) for code, part in _split_code(markdown))
    return " ".join(out.split())


def _prose_only(markdown: str, *, drop_quoted: bool = False) -> str:
    """Return the text outside code spans (and, optionally, outside double quotes)."""
    prose = " ".join(part for code, part in _split_code(markdown) if not code)
    return _QUOTED_RE.sub(" ", prose) if drop_quoted else prose


def _requirement(block: _Block) -> Requirement:
    """Build the requirement of a block that starts with a bold requirement ID."""
    match = _REQ_START_RE.match(block.raw)
    if not match:
        raise CatalogueError(f"line {block.line}: malformed requirement identifier")
    req_id, body = match.group(1), match.group(2)
    keyword = _KEYWORD_RE.search(_prose_only(body))
    if keyword is None:
        raise CatalogueError(f"line {block.line}: {req_id} has no RFC 2119 key word in capitals")
    if block.section is None:
        raise CatalogueError(f"line {block.line}: {req_id} is not inside a numbered section")
    extensions = set(_EXT_MARK_RE.findall(body))
    if len(extensions) > 1:
        raise CatalogueError(f"line {block.line}: {req_id} names several extensions")
    return Requirement(
        id=req_id,
        level=_KEYWORD_LEVEL[keyword.group(1)],
        section=block.section,
        text=_plain_text(body),
        extension=extensions.pop() if extensions else None,
    )


def extract_requirements(markdown: str) -> list[Requirement]:
    """Extract every requirement of the spec prose, in document order.

    Raises CatalogueError for a requirement paragraph without an RFC 2119 key word, a malformed
    or duplicate identifier, a requirement outside a numbered section, or two extension marks.
    """
    found: list[Requirement] = []
    seen: dict[str, int] = {}
    for block in _blocks(markdown):
        if not block.raw.startswith("**OA-"):
            continue
        req = _requirement(block)
        if req.id in seen:
            raise CatalogueError(
                f"line {block.line}: duplicate requirement {req.id} (first at line {seen[req.id]})"
            )
        seen[req.id] = block.line
        found.append(req)
    return found


def find_stray_keywords(markdown: str) -> list[tuple[int, str]]:
    """Return (line, key word) for capitalised RFC 2119 key words outside requirements.

    Informative prose uses lower-case words; key words in code spans and inside double quotes
    (the BCP 14 boilerplate) are not counted. Tables are checked like prose; headings and code
    blocks are not.
    """
    stray: list[tuple[int, str]] = []
    for block in _blocks(markdown):
        if block.raw.startswith("**OA-"):
            continue
        for match in _KEYWORD_RE.finditer(_prose_only(block.raw, drop_quoted=True)):
            stray.append((block.line, match.group(1)))
    return stray


def cited_ids(text: str) -> set[str]:
    """Return every requirement ID (OA-GROUP-N) cited anywhere in `text`."""
    return set(_CITED_RE.findall(text))


def render_catalogue(requirements: Iterable[Requirement]) -> bytes:
    """Render requirements as the catalogue XML (deterministic: document order, fixed layout)."""
    root = etree.Element("requirements", nsmap={"xsi": XSI})
    root.set(f"{{{XSI}}}noNamespaceSchemaLocation", "../schemas/requirements.xsd")
    root.set("spec", "OpenAIR")
    root.set("version", "1.0")
    for req in requirements:
        el = etree.SubElement(root, "requirement", id=req.id, level=req.level)
        el.set("section", req.section)
        if req.extension is not None:
            el.set("extension", req.extension)
        el.text = req.text
    body: bytes = etree.tostring(root, encoding="UTF-8", xml_declaration=False, pretty_print=True)
    return _HEADER + body


def load_catalogue(path: Path | str | None = None) -> dict[str, Requirement]:
    """Read spec/requirements.xml into a dict keyed by requirement ID, in document order."""
    source = Path(path) if path is not None else DEFAULT_CATALOGUE
    parser = etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False
    )
    try:
        root = etree.parse(str(source), parser).getroot()
    except etree.XMLSyntaxError as exc:
        raise CatalogueError(f"{source}: {exc}") from exc
    if root.tag != "requirements":
        raise CatalogueError(f"{source}: root element is {root.tag!r}, not 'requirements'")
    catalogue: dict[str, Requirement] = {}
    for el in root.iterchildren("requirement"):
        req = Requirement(
            id=el.get("id", ""),
            level=el.get("level", ""),
            section=el.get("section", ""),
            text=el.text or "",
            extension=el.get("extension"),
        )
        if req.id in catalogue:
            raise CatalogueError(f"{source}: duplicate requirement {req.id}")
        catalogue[req.id] = req
    return catalogue
