"""The psySpec file (spec section 12): what a system is made of, as every role reads it.

`load_config(path)` reads a psySpec file through the hardened parser (no DTD, OA-SEC-1/2),
validates it against `schemas/psyspec.xsd` (OA-CONF-1) and reports the first error as
`path:line: message` (OA-CONF-3). `default_config()` is the configuration of a server started
without one: the psySpec named `Default built-in` with AIRCentral, WB1 and WB2 (OA-WB-1).
`name_problem` is the naming rule of modules, whiteboards and streams (OA-SESS-30) and
`SYSTEM_COMPONENTS` the names every server hosts besides its whiteboards (spec 6.2).

The server reads its configuration here (`openair.server.core.config` adds its limits); the
ontology tools read a system's modules from it without importing the server (issue #17).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

from lxml import etree

from openair.protocol.content import Registration, RegistrationForm
from openair.protocol.errors import XmlForbiddenError, XmlMalformedError, XmlTooDeepError
from openair.protocol.registration import parse_registration_element
from openair.protocol.xmlsafe import XmlLimits, parse_xml
from openair.resources import schema_path

__all__ = [
    "AIRCENTRAL",
    "DEFAULT_MAXCOUNT",
    "DEFAULT_WB_PRIORITY",
    "SYSTEM_COMPONENTS",
    "ConfigError",
    "ModuleConfig",
    "ServerConfig",
    "StreamConfig",
    "WhiteboardConfig",
    "default_config",
    "load_config",
    "name_problem",
    "parse_config",
]

AIRCENTRAL = "AIRCentral"  # OA-WB-1, OA-CONF-4
#: The components every server hosts besides its whiteboards (spec 6.2).
SYSTEM_COMPONENTS = ("CNS", "Config", "Psyclone", "AIRServer", "ContextsAndPhases")
DEFAULT_MAXCOUNT = 10_000  # OA-CONF-2, OA-WB-6
DEFAULT_WB_PRIORITY = 1.0  # OA-CONF-2
MAX_NAME_BYTES = 255  # OA-SESS-30
GLOBAL_ENTRIES = ("port", "title", "description", "htmldir", "datastorefile")


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamConfig:
    """One `<stream>` of a whiteboard (spec 11.1, 12.1); other attributes are kept as text."""

    name: str
    maxsize: float = 10.0  # units of 1 048 576 bytes
    maxcount: int = 0  # samples; 0 = no count limit
    attributes: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class WhiteboardConfig:
    """One `<whiteboard name maxcount priority>` (OA-CONF-2)."""

    name: str
    maxcount: int = DEFAULT_MAXCOUNT
    priority: float = DEFAULT_WB_PRIORITY
    streams: tuple[StreamConfig, ...] = ()
    # Placement in a cluster (spec 17, OA-CLU-6): the node (placement tag) that holds it, from
    # `host` or Psyclone's `remote`; and how many nodes keep a copy. Ignored by a lone server.
    host: str = ""
    replicas: int = 1


@dataclass(frozen=True, slots=True, kw_only=True)
class ModuleConfig:
    """One `<module>`: its registration and its raw XML for GET_ENTRY (OA-CONF-5, OA-SESS-12)."""

    name: str
    registration: Registration
    spec_xml: str
    internal: str = ""  # OA-CONF-8: `package.module:name` of an internal module's code, or ""


@dataclass(frozen=True, slots=True, kw_only=True)
class ServerConfig:
    """A whole configuration. `globals` holds the `<global>` entries by name (port, title, …).

    `source` is the file it was read from ("" when built in, the GET_ENTRY `spec` entry);
    `ignored` names the psySpec elements the server accepts but does not implement (OA-CONF-6).
    """

    name: str = "OpenAIR"
    whiteboards: tuple[WhiteboardConfig, ...] = (WhiteboardConfig(name=AIRCENTRAL),)
    modules: tuple[ModuleConfig, ...] = ()
    globals: tuple[tuple[str, str], ...] = ()
    source: str = ""
    ignored: tuple[str, ...] = ()

    def global_entry(self, key: str, default: str = "") -> str:
        """Return the `<global>` entry `key`, or `default`."""
        return next((v for k, v in self.globals if k == key), default)

    @property
    def port(self) -> int | None:
        """The `<global><port>` (OA-CONF-7), or None when the configuration sets none."""
        text = self.global_entry("port")
        return int(text) if text.strip().isdigit() else None

    def module(self, name: str) -> ModuleConfig | None:
        """Return the configuration of module `name` (exact case), if any."""
        return next((m for m in self.modules if m.name == name), None)


class ConfigError(Exception):
    """A configuration the server refuses to start with (OA-CONF-3): `path:line: message`."""


_DEFAULT_PSYSPEC = """\
<psySpec name="Default built-in" version="1.2">
  <global>
    <title>Psyclone Default</title>
    <description>Default built-in PsySpec</description>
    <htmldir>html</htmldir>
  </global>
  <whiteboard name="AIRCentral"/>
  <whiteboard name="WB1">
    <streams><stream name="Stream1" maxsize="10"/></streams>
  </whiteboard>
  <whiteboard name="WB2">
    <streams><stream name="Stream2" maxsize="10"/></streams>
  </whiteboard>
</psySpec>
"""

_BAD_NAME_CHAR = re.compile(r"[\s;\x00-\x1f\x7f-\x9f\u0085\u00a0\u1680\u2000-\u200a\u2028\u2029]")
_LINE_IN_DETAIL = re.compile(r"line (\d+)")
_IMPLEMENTED = frozenset({"global", "whiteboard", "module"})


def name_problem(name: str) -> str | None:
    """Return why `name` is not a valid module, whiteboard or stream name (OA-SESS-30)."""
    if not name:
        return "the name is empty"
    if len(name.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES:
        return f"the name is longer than {MAX_NAME_BYTES} bytes"
    if _BAD_NAME_CHAR.search(name):
        return "the name contains white space, a control character or ';'"
    return None


@lru_cache(maxsize=1)
def _psyspec_schema() -> etree.XMLSchema:
    """Load schemas/psyspec.xsd (a trusted, shipped file; it includes its sibling schemas)."""
    return etree.XMLSchema(etree.parse(str(schema_path("psyspec.xsd"))))


def default_config() -> ServerConfig:
    """Return the configuration of a server started without one (OA-WB-1, OA-STREAM-15)."""
    return parse_config(_DEFAULT_PSYSPEC.encode("utf-8"), source="")


def load_config(path: str | Path) -> ServerConfig:
    """Read, validate and return the psySpec file at `path`; raise ConfigError (OA-CONF-3)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}:0: cannot read the configuration: {exc.strerror}") from None
    return parse_config(data, source=str(path))


def parse_config(data: bytes, *, source: str, max_triggers: int = 1024) -> ServerConfig:
    """Parse and validate psySpec bytes; errors name `source` and the line (OA-CONF-3)."""
    shown = source or "<built-in>"
    root = _parse(data, shown)
    _validate(root, shown)
    whiteboards = tuple(_whiteboard(el) for el in _children(root, "whiteboard"))
    if not any(wb.name == AIRCENTRAL for wb in whiteboards):
        whiteboards = (WhiteboardConfig(name=AIRCENTRAL), *whiteboards)  # OA-CONF-4
    _check_names(root, shown)
    modules = tuple(_module(el, shown, max_triggers) for el in _children(root, "module"))
    return ServerConfig(
        name=root.get("name", ""),
        whiteboards=whiteboards,
        modules=modules,
        globals=_globals(root),
        source=source,
        ignored=_ignored(root),
    )


def _parse(data: bytes, shown: str) -> etree._Element:
    """Parse with the hardened parser (OA-CONF-1, OA-SEC-1/2), mapping errors to lines."""
    try:
        return parse_xml(data, XmlLimits(max_bytes=max(len(data), 1)))
    except XmlForbiddenError as exc:
        found = re.search(rb"<!", data)
        at = data.count(b"\n", 0, found.start()) + 1 if found else 1
        raise ConfigError(f"{shown}:{at}: {exc}") from None
    except (XmlMalformedError, XmlTooDeepError) as exc:
        lines = _LINE_IN_DETAIL.findall(exc.detail)
        line = lines[-1] if lines else "1"
        raise ConfigError(f"{shown}:{line}: {exc}") from None


def _validate(root: etree._Element, shown: str) -> None:
    """Check the root is psySpec and the document is valid against psyspec.xsd (OA-CONF-1)."""
    if root.tag != "psySpec":
        raise ConfigError(
            f"{shown}:{root.sourceline or 1}: the root must be psySpec, not {root.tag}"
        )
    schema = _psyspec_schema()
    if not schema.validate(root):
        log: Any = schema.error_log  # the stubs declare _ErrorLog empty
        first = log[0]  # libxml2 reports in document order
        raise ConfigError(f"{shown}:{first.line}: {first.message}")


def _children(root: etree._Element, tag: str) -> list[etree._Element]:
    return [el for el in root if el.tag == tag]


def _whiteboard(el: etree._Element) -> WhiteboardConfig:
    """Read one `<whiteboard>` with its defaults (OA-CONF-2); the XSD checked the values."""
    streams = tuple(
        _stream(stream)
        for group in el
        if group.tag == "streams"
        for stream in group
        if stream.tag == "stream"
    )
    return WhiteboardConfig(
        name=el.get("name", ""),
        maxcount=int(el.get("maxcount", DEFAULT_MAXCOUNT)),
        priority=float(el.get("priority", DEFAULT_WB_PRIORITY)),
        streams=streams,
        host=el.get("host") or el.get("remote") or "",
        replicas=int(el.get("replicas", "1")),
    )


def _stream(el: etree._Element) -> StreamConfig:
    other = tuple((k, v) for k, v in el.attrib.items() if k not in ("name", "maxsize", "maxcount"))
    return StreamConfig(
        name=el.get("name", ""),
        maxsize=float(el.get("maxsize", "10")),
        maxcount=int(el.get("maxcount", "0")),
        attributes=tuple((str(k), str(v)) for k, v in other),
    )


def _check_names(root: etree._Element, shown: str) -> None:
    """Refuse whiteboard, stream and module names that CNS could not serve (OA-SESS-30)."""
    named = [
        el
        for el in root.iter("whiteboard", "module", "stream")
        if el.getparent() is root or el.tag == "stream"
    ]
    for el in named:
        name = el.get("name", "")
        problem = name_problem(name)
        if problem is None and name in SYSTEM_COMPONENTS:
            problem = "the name is that of a system component"
        if problem is not None:
            raise ConfigError(f"{shown}:{el.sourceline}: {el.tag} {name!r}: {problem}")


def _module(el: etree._Element, shown: str, max_triggers: int) -> ModuleConfig:
    """Read one `<module>`: its registration (OA-CONF-5) and its XML for GET_ENTRY."""
    name = el.get("name", "")
    try:
        reg = parse_registration_element(name, el, max_triggers=max_triggers)
    except Exception as exc:  # any refusal of the registration parser is a config error
        raise ConfigError(f"{shown}:{el.sourceline}: module {name!r}: {exc}") from None
    xml = etree.tostring(el, encoding="unicode", with_tail=False)
    return ModuleConfig(
        name=name,
        registration=replace(reg, form=RegistrationForm.CONFIG),
        spec_xml=xml,
        internal=el.get("internal", "").strip(),  # OA-CONF-8; psyspec.xsd checks the form
    )


def _globals(root: etree._Element) -> tuple[tuple[str, str], ...]:
    """Return the text entries of `<global>` in document order (OA-SESS-12, OA-CONF-7)."""
    entries: list[tuple[str, str]] = []
    for glob in _children(root, "global"):
        for child in glob:
            if isinstance(child.tag, str) and child.tag in GLOBAL_ENTRIES:
                entries.append((child.tag, (child.text or "").strip()))
    return tuple(entries)


def _ignored(root: etree._Element) -> tuple[str, ...]:
    """Name the accepted but unimplemented elements, for the start-up report (OA-CONF-6)."""
    found: list[str] = []
    for el in root:
        if not isinstance(el.tag, str):
            continue
        if el.tag not in _IMPLEMENTED:
            found.append(f"line {el.sourceline}: <{el.tag}>")
        elif el.tag == "global":
            found.extend(
                f"line {c.sourceline}: <global><{c.tag}>"
                for c in el
                if isinstance(c.tag, str) and c.tag not in GLOBAL_ENTRIES
            )
    return tuple(found)
