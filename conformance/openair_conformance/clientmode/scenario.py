"""Client-conformance scenarios: language-neutral XML files, loaded and checked against an XSD.

A scenario (`scenarios/CLI-NNN-*.xml`, schema `schemas/scenario.xsd`) names its stable ID, title,
requirements, level and spec section, the peer the library talks to, the steps (shim commands,
posts and retrieves by the kit itself, deliveries the kit makes to the module) and the wire
checks run over everything the library sent. `load_scenarios()` reads every file of the folder;
a file that is not well-formed, breaks the schema, cites a requirement twice or reuses an ID is
refused with `ScenarioError` naming the file and line.

The loaded form is deliberately generic: a `Step` keeps its element name, attributes, items
(triggers, retrieve specs) and expectations; the runner (runner.py) gives them meaning.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from lxml import etree

from openair.protocol.errors import OpenAIRError
from openair.protocol.xmlsafe import XmlLimits, parse_xml
from openair_conformance.model import CaseInfo, Level

__all__ = [
    "SCENARIO_DIR",
    "SCHEMA_PATH",
    "WIRE_CHECKS",
    "Expect",
    "PeerSpec",
    "Scenario",
    "ScenarioError",
    "Step",
    "load_scenario",
    "load_scenarios",
    "parse_scenario",
    "select_scenarios",
]

_PACKAGE = Path(__file__).resolve().parent.parent
SCENARIO_DIR = _PACKAGE / "scenarios"
SCHEMA_PATH = _PACKAGE / "schemas" / "scenario.xsd"
_LIMITS = XmlLimits(max_bytes=1 << 20, max_depth=16)

#: The wire checks and the requirements each one enforces (schemas/scenario.xsd, WireCheckType).
WIRE_CHECKS: dict[str, tuple[str, ...]] = {
    "decodes": ("OA-MSG-1",),
    "canonical": ("OA-MSG-4",),
    "posted-time": ("OA-TIME-2",),
    "callback-opened": ("OA-SESS-7", "OA-FRAME-10"),
    "acks": ("OA-SESS-2", "OA-SESS-11", "OA-DELIV-4", "OA-KEEP-2", "OA-SESS-28"),
    "extensions": ("OA-GEN-2",),
}
_TESTS = ("equals", "not-equals", "count", "min", "present", "one-of")


class ScenarioError(Exception):
    """A scenario file cannot be used (`path:line: what`)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Expect:
    """One check of a step's result: `path` `test` `value` (README of the XSD, ExpectType)."""

    path: str
    test: str
    value: str
    requirement: str = ""
    line: int = 0

    def describe(self) -> str:
        """`trigger.type equals Conf.X` (placeholders unexpanded)."""
        return f"{self.path} {self.test} {self.value!r}"


@dataclass(frozen=True, slots=True, kw_only=True)
class Step:
    """One step: its element name, attributes, items (trigger/retrieve/spec) and expectations."""

    kind: str
    attrs: tuple[tuple[str, str], ...] = ()
    items: tuple[tuple[str, tuple[tuple[str, str], ...]], ...] = ()
    expects: tuple[Expect, ...] = ()
    line: int = 0

    def get(self, name: str, default: str = "") -> str:
        """The attribute `name`, or `default` when absent."""
        return next((value for key, value in self.attrs if key == name), default)

    def has(self, name: str) -> bool:
        """Whether the attribute `name` is present."""
        return any(key == name for key, _ in self.attrs)

    def flag(self, name: str, default: bool) -> bool:
        """A boolean attribute (XSD boolean: true, false, 1, 0)."""
        return self.get(name, "true" if default else "false") in ("true", "1")

    def children(self, kind: str) -> list[dict[str, str]]:
        """The attributes of every item element named `kind`, in document order."""
        return [dict(attrs) for name, attrs in self.items if name == kind]


@dataclass(frozen=True, slots=True, kw_only=True)
class PeerSpec:
    """The peer: the reference server behind the kit's proxy, misbehaving as `kind` says."""

    kind: str = "reference"
    delay_ms: int = 0
    on_type: str = ""
    drop_after: int = 0  # drop-push: close the push connection after this many samples


@dataclass(frozen=True, slots=True, kw_only=True)
class Scenario:
    """A loaded scenario; `info` is what reports show (requirements include the wire checks')."""

    info: CaseInfo
    description: str
    peer: PeerSpec
    steps: tuple[Step, ...]
    wire_checks: tuple[str, ...] = ()
    source: str = ""


@cache
def _schema() -> etree.XMLSchema:
    return etree.XMLSchema(parse_xml(SCHEMA_PATH.read_bytes(), _LIMITS))


def _elements(el: etree._Element, name: str | None = None) -> list[etree._Element]:
    return [c for c in el if isinstance(c.tag, str) and (name is None or c.tag == name)]


def _line(el: etree._Element) -> int:
    return el.sourceline if isinstance(el.sourceline, int) else 0


def _attrs(el: etree._Element) -> tuple[tuple[str, str], ...]:
    return tuple((str(k), str(v)) for k, v in el.attrib.items())


def _expect(el: etree._Element) -> Expect:
    test = next(name for name in _TESTS if name in el.attrib)  # the XSD cannot say "one of"
    return Expect(
        path=el.get("path", ""),
        test=test,
        value=el.get(test, ""),
        requirement=el.get("requirement", ""),
        line=_line(el),
    )


def _step(el: etree._Element) -> Step:
    items = tuple(
        (str(child.tag), _attrs(child)) for child in _elements(el) if child.tag != "expect"
    )
    return Step(
        kind=str(el.tag),
        attrs=_attrs(el),
        items=items,
        expects=tuple(_expect(e) for e in _elements(el, "expect")),
        line=_line(el),
    )


def _text(el: etree._Element | None) -> str:
    if el is None:
        return ""
    text = "".join(t if isinstance(t, str) else t.decode() for t in el.itertext())
    lines = [line.strip() for line in text.strip().splitlines()]
    return "\n".join(lines)


def _check_expects(root: etree._Element, source: str) -> None:
    for el in root.iter("expect"):
        tests = [name for name in _TESTS if name in el.attrib]
        if len(tests) != 1:
            raise ScenarioError(f"{source}:{_line(el)}: an expect needs exactly one of {_TESTS}")


def parse_scenario(data: bytes, source: str = "<bytes>") -> Scenario:
    """Parse and validate one scenario document; ScenarioError names the line at fault."""
    try:
        root = parse_xml(data, _LIMITS)
    except OpenAIRError as exc:
        raise ScenarioError(f"{source}: {exc}") from exc
    try:
        _schema().assertValid(root)
    except etree.DocumentInvalid as exc:  # its message names the line
        raise ScenarioError(f"{source}: {exc}") from exc
    _check_expects(root, source)
    requirements = [el.get("id", "") for el in _elements(root, "requirement")]
    if len(set(requirements)) != len(requirements):
        raise ScenarioError(f"{source}: a requirement is cited twice")
    checks = tuple(el.get("name", "") for el in root.iter("check"))
    for check in checks:
        requirements += [r for r in WIRE_CHECKS[check] if r not in requirements]
    for el in root.iter():
        cited = el.get("requirement") if isinstance(el.tag, str) else None
        if cited and cited not in requirements:
            raise ScenarioError(f"{source}:{_line(el)}: {cited} is not among the requirements")
    peer = _elements(root, "peer")[0]
    info = CaseInfo(
        id=root.get("id", ""),
        title=_text(_elements(root, "title")[0]),
        section=root.get("section", ""),
        requirements=tuple(requirements),
        level=Level(root.get("level", "MUST")),
        allowed=tuple(_text(el) for el in _elements(root, "allowed")),
    )
    described = _elements(root, "description")
    return Scenario(
        info=info,
        description=_text(described[0]) if described else "",
        peer=PeerSpec(
            kind=peer.get("kind", "reference"),
            delay_ms=int(peer.get("delay-ms", "0")),
            on_type=peer.get("on-type", ""),
            drop_after=int(peer.get("drop-after", "1" if peer.get("kind") == "drop-push" else "0")),
        ),
        steps=tuple(_step(el) for el in _elements(_elements(root, "steps")[0])),
        wire_checks=checks,
        source=source,
    )


def load_scenario(path: Path | str) -> Scenario:
    """Read and parse one scenario file."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    return parse_scenario(data, str(path))


def load_scenarios(folder: Path | str | None = None) -> list[Scenario]:
    """Load every `*.xml` scenario of `folder` (default: the shipped ones), sorted by ID."""
    root = Path(folder) if folder is not None else SCENARIO_DIR
    scenarios = [load_scenario(path) for path in sorted(root.glob("*.xml"))]
    seen: dict[str, str] = {}
    for scenario in scenarios:
        earlier = seen.setdefault(scenario.info.id, scenario.source)
        if earlier != scenario.source:
            raise ScenarioError(f"{scenario.source}: ID {scenario.info.id} is also {earlier}")
    return sorted(scenarios, key=lambda s: s.info.id)


def select_scenarios(scenarios: Iterable[Scenario], globs: Sequence[str] = ()) -> list[Scenario]:
    """The scenarios whose ID matches one of `globs` (fnmatch, case-sensitive); all without."""
    return [
        s
        for s in scenarios
        if not globs or any(fnmatch.fnmatchcase(s.info.id, glob) for glob in globs)
    ]
