"""The texts a retrieve `content` glob is matched against (spec 9.2).

- `canonical_xml_text(content)` is the canonical XML text of XML content (OA-RET-17), what a
  `contentmatch="xml"` glob sees (OA-RET-13): comments and processing instructions removed,
  white-space-only character data removed at every level, empty elements written `<name/>`,
  attributes as `name="value"` in the order received, a fixed set of escapes.
- `text_content(content)` is the text content of XML content (OA-RET-18), what a plain glob
  sees (OA-RET-8): the kept character data concatenated without separators.

Both walk the parsed tree instead of serializing it with lxml, so the result is the spec's text
and not a library's choices (quote style, escapes, `<c></c>` against `<c/>`).
"""

from __future__ import annotations

from collections.abc import Callable

from lxml import etree

from openair.protocol.errors import OpenAIRError
from openair.protocol.message import Message
from openair.protocol.xmlsafe import parse_xml

__all__ = ["canonical_xml_text", "content_glob", "text_content", "text_of"]

_WS = " \t\n\r"  # the white space of XML 1.0 (OA-RET-17)
_XML_NS = "http://www.w3.org/XML/1998/namespace"
_TEXT_ESCAPES = str.maketrans({"&": "&amp;", "<": "&lt;", ">": "&gt;", "\r": "&#13;"})
_ATTR_ESCAPES = str.maketrans(
    {
        "&": "&amp;",
        "<": "&lt;",
        ">": "&gt;",
        '"': "&quot;",
        "\r": "&#13;",
        "\t": "&#9;",
        "\n": "&#10;",
    }
)

# A node of the cleaned tree: kept character data (str) or an element.
_Node = str | etree._Element


def _wrapper(content: str) -> etree._Element:
    """Parse XML content inside a wrapper element, with the hardened parser (OA-SEC-1/2)."""
    return parse_xml(b"<c>" + content.encode("utf-8") + b"</c>")


def _children(el: etree._Element) -> list[_Node]:
    """Return the element and text children of `el` as OA-RET-17 keeps them.

    Comments and processing instructions go first, so the text around one is one run; then a
    run that is only white space goes too.
    """
    nodes: list[_Node] = []
    run = el.text or ""
    for child in el:
        if isinstance(child.tag, str):
            if run.strip(_WS):
                nodes.append(run)
            nodes.append(child)
            run = ""
        run += child.tail or ""
    if run.strip(_WS):
        nodes.append(run)
    return nodes


def _qualified(el: etree._Element, clark: str) -> str:
    """Return an attribute's name as received: `prefix:local` for a namespaced one."""
    if not clark.startswith("{"):
        return clark
    uri, local = clark[1:].split("}", 1)
    if uri == _XML_NS:
        return "xml:" + local
    prefix = next((p for p, u in el.nsmap.items() if u == uri and p is not None), None)
    return f"{prefix}:{local}" if prefix else local


def _write(el: etree._Element, parent_ns: dict[str | None, str], out: list[str]) -> None:
    """Append the canonical XML text of `el` to `out` (OA-RET-17)."""
    name = etree.QName(el).localname
    name = f"{el.prefix}:{name}" if el.prefix else name
    out.append("<" + name)
    nsmap = el.nsmap
    for prefix, uri in nsmap.items():  # the declarations new at this element, in order
        if parent_ns.get(prefix) != uri:
            attr = f"xmlns:{prefix}" if prefix else "xmlns"
            out.append(f' {attr}="{uri.translate(_ATTR_ESCAPES)}"')
    for key, value in el.attrib.items():
        out.append(f' {_qualified(el, str(key))}="{str(value).translate(_ATTR_ESCAPES)}"')
    children = _children(el)
    if not children:
        out.append("/>")
        return
    out.append(">")
    for node in children:
        if isinstance(node, str):
            out.append(node.translate(_TEXT_ESCAPES))
        else:
            _write(node, dict(nsmap), out)
    out.append(f"</{name}>")


def _text(el: etree._Element, out: list[str]) -> None:
    """Append the kept character data of `el` to `out`, in document order (OA-RET-18)."""
    for node in _children(el):
        if isinstance(node, str):
            out.append(node)
        else:
            _text(node, out)


def canonical_xml_text(content: str) -> str:
    """Return the canonical XML text of XML content (OA-RET-17).

    Content that does not parse (the server stores only content that did) is returned as is.
    """
    try:
        wrapper = _wrapper(content)
    except OpenAIRError:
        return content
    out: list[str] = []
    for node in _children(wrapper):
        if isinstance(node, str):
            out.append(node.translate(_TEXT_ESCAPES))
        else:
            _write(node, {}, out)
    return "".join(out)


def text_content(content: str) -> str:
    """Return the text content of XML content (OA-RET-18); empty when it does not parse."""
    try:
        wrapper = _wrapper(content)
    except OpenAIRError:
        return ""
    out: list[str] = []
    _text(wrapper, out)
    return "".join(out)


def content_glob(pattern: str) -> Callable[[str], bool]:
    """Return a matcher for a retrieve `content` glob (OA-RET-8).

    `*` matches any run of characters; every other character, `?` included, is literal; the
    whole text must match, case-sensitively.
    """
    parts = pattern.split("*")
    if len(parts) == 1:
        return pattern.__eq__
    pre, post, middles = parts[0], parts[-1], parts[1:-1]

    def match(text: str) -> bool:
        end = len(text) - len(post)
        if end < len(pre) or not text.startswith(pre) or not text.endswith(post):
            return False
        pos = len(pre)
        # Leftmost placement of each middle part is optimal for `*`-only globs.
        for middle in middles:
            found = text.find(middle, pos, end)
            if found < 0:
                return False
            pos = found + len(middle)
        return True

    return match


def text_of(msg: Message) -> str:
    """Return a message's text content (OA-RET-18): its text, or that of its XML content."""
    return text_content(msg.content) if msg.content_is_xml else msg.content
