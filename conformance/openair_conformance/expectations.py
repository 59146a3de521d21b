"""Expectations files: per implementation, which cases are known not to pass, and why.

```xml
<expectations implementation="Psyclone 1.1.7">
  <expect case="HOST-001" verdict="fail" deviation="DEV-16"
          reason="malformed XML is acknowledged" link="spec/openair-1.0.md#appendix-a"/>
  <expect case="*" requirement="OA-CC-2" verdict="fail" reason="…"/>
</expectations>
```

A file is validated against `schemas/expectations.xsd` (lxml). For each case the first entry in
document order whose `case` glob matches the ID (and whose `requirement`, when given, is cited
by the case) applies: a case that gets the expected verdict becomes expected-failure, a case
that passes becomes unexpected-pass, any other verdict is kept (the reason is still attached).
An entry expecting `pass` changes nothing; placed first, it shields a case from a broader entry.
Entries that match no registered case are reported (`unknown_entries`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from fnmatch import fnmatchcase
from functools import cache
from importlib import resources
from pathlib import Path

from lxml import etree

from openair_conformance.model import CaseInfo, Verdict

__all__ = [
    "SHIPPED_DIR",
    "Expectation",
    "ExpectationError",
    "Expectations",
    "apply_expectation",
    "find_expectation",
    "load_expectations",
    "parse_expectations",
    "resolve_expectations_path",
    "unknown_entries",
]

#: Folder of the expectations files shipped with the suite (`psyclone-1.1.7.xml`, …).
SHIPPED_DIR = Path(str(resources.files("openair_conformance") / "expectations"))
_SCHEMA = Path(str(resources.files("openair_conformance") / "schemas" / "expectations.xsd"))

#: The verdicts an expectation may name (schemas/expectations.xsd, ExpectedVerdictType).
EXPECTABLE = frozenset(
    {
        Verdict.PASS,
        Verdict.FAIL,
        Verdict.PASS_NONSTRICT,
        Verdict.INFORMATIONAL,
        Verdict.TIMING,
        Verdict.INCONCLUSIVE,
        Verdict.ERROR,
    }
)
# A Fail raised by a case becomes FAIL, PASS_NONSTRICT or INFORMATIONAL depending on its level;
# an entry expecting "fail" covers all three, so one file serves cases of every level.
#: Verdicts an entry expecting `fail` covers. TIMING is one of them: an expected deviation
#: (a legacy server closing a connection after 13 s instead of at once) lands in the grace
#: window when --timeout-scale widens it, and is then late rather than absent — the same
#: deviation, not a new timing problem.
_FAIL_FAMILY = frozenset(
    {Verdict.FAIL, Verdict.PASS_NONSTRICT, Verdict.INFORMATIONAL, Verdict.TIMING}
)


class ExpectationError(ValueError):
    """An expectations file cannot be read or is not valid against its schema."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Expectation:
    """One `<expect>` entry."""

    case: str
    verdict: Verdict
    reason: str
    link: str = ""
    requirement: str = ""
    deviation: str = ""
    line: int = 0

    def applies_to(self, info: CaseInfo) -> bool:
        """Return whether this entry covers the case `info`."""
        if not fnmatchcase(info.id, self.case):
            return False
        return not self.requirement or self.requirement in info.requirements

    @property
    def label(self) -> str:
        """A short name for reports: the glob, narrowed by the requirement if any."""
        return f"{self.case}[{self.requirement}]" if self.requirement else self.case

    def describe(self) -> str:
        """The text shown with a result: deviation, reason and link."""
        text = f"{self.deviation}: {self.reason}" if self.deviation else self.reason
        return f"{text} ({self.link})" if self.link else text


@dataclass(frozen=True, slots=True, kw_only=True)
class Expectations:
    """A parsed expectations file."""

    implementation: str
    entries: tuple[Expectation, ...] = ()
    source: str = ""


@cache
def _schema() -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(_SCHEMA)))


def _parser() -> etree.XMLParser:
    # The same hardening as everywhere (style rule 6): no DTD, no entities, no network.
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False
    )


def parse_expectations(data: bytes, source: str = "<bytes>") -> Expectations:
    """Parse and validate an expectations document; ExpectationError names the line at fault."""
    try:
        tree = etree.fromstring(data, _parser()).getroottree()
    except etree.XMLSyntaxError as exc:
        raise ExpectationError(f"{source}: {exc}") from exc
    if getattr(tree.docinfo, "doctype", ""):
        raise ExpectationError(f"{source}: a DOCTYPE is not allowed")
    try:
        _schema().assertValid(tree)
    except etree.DocumentInvalid as exc:  # its message names the line
        raise ExpectationError(f"{source}: {exc}") from exc
    root = tree.getroot()
    entries = tuple(
        Expectation(
            case=el.get("case", ""),
            verdict=Verdict(el.get("verdict", "")),
            reason=el.get("reason", "").strip(),
            link=el.get("link", ""),
            requirement=el.get("requirement", ""),
            deviation=el.get("deviation", ""),
            line=el.sourceline if isinstance(el.sourceline, int) else 0,
        )
        for el in root.iterchildren("expect")
    )
    return Expectations(
        implementation=root.get("implementation", ""), entries=entries, source=source
    )


def resolve_expectations_path(spec: str | Path) -> Path:
    """Return the file for `spec`: an existing path, or the name of a shipped file.

    `psyclone-1.1.7` (or `psyclone-1.1.7.xml`) names `expectations/psyclone-1.1.7.xml` of the
    suite. Raises ExpectationError when neither exists.
    """
    path = Path(spec)
    if path.is_file():
        return path
    name = path.name if path.suffix == ".xml" else f"{path.name}.xml"
    shipped = SHIPPED_DIR / name
    if str(spec) == path.name and shipped.is_file():
        return shipped
    known = ", ".join(sorted(p.stem for p in SHIPPED_DIR.glob("*.xml")))
    raise ExpectationError(f"{spec}: no such file (shipped expectations: {known or 'none'})")


def load_expectations(spec: str | Path) -> Expectations:
    """Read and validate an expectations file (a path, or the name of a shipped file)."""
    path = resolve_expectations_path(spec)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ExpectationError(f"{path}: {exc.strerror}") from exc
    return parse_expectations(data, source=str(path))


def find_expectation(expectations: Expectations | None, info: CaseInfo) -> Expectation | None:
    """Return the first entry that applies to the case, in document order."""
    if expectations is None:
        return None
    return next((e for e in expectations.entries if e.applies_to(info)), None)


def apply_expectation(verdict: Verdict, expectation: Expectation | None) -> Verdict:
    """Return the verdict after the expectation: expected-failure, unexpected-pass or as is."""
    if expectation is None or expectation.verdict == Verdict.PASS:
        return verdict  # a "pass" entry only shields the case from broader entries below it
    wanted = expectation.verdict
    if verdict == wanted or (wanted == Verdict.FAIL and verdict in _FAIL_FAMILY):
        return Verdict.EXPECTED_FAILURE
    if verdict == Verdict.PASS:
        return Verdict.UNEXPECTED_PASS
    return verdict


def unknown_entries(
    expectations: Expectations | None, infos: Iterable[CaseInfo]
) -> tuple[str, ...]:
    """Return a description of each entry that matches no registered case."""
    if expectations is None:
        return ()
    known = list(infos)
    return tuple(
        f"{expectations.source}:{entry.line}: {entry.label}"
        for entry in expectations.entries
        if not any(entry.applies_to(info) for info in known)
    )
