"""Draft an ontology from a recorded history (`openair ontology infer`).

Every valid type observed becomes a message type node (`kind="message"`), with an `<observed>`
element (count, first and last time, whiteboards), one `<poster>` per module and whiteboard that
posted it (most frequent first), the latest content as an `<example>`, and for XML content the
root element it had. Nodes in between are groups. Descriptions, namespaces, families
(`parameter`) and deprecations are left for people to write: the result is a skeleton.

Types that are not valid (OA-TYPE-1; Psyclone 1.1.7 stores some, DEV-5) are left out and
counted in the report.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from openair.protocol.errors import OpenAIRError
from openair.protocol.matching import ascii_fold
from openair.protocol.message import Message
from openair.protocol.psyspec import name_problem
from openair.protocol.xmlsafe import local_name, parse_fragment
from openair_ontology.model import ContentSpec, Example, Kind, Link, Observed, Ontology, TypeNode
from openair_ontology.parse import indent_xml
from openair_ontology.usage import Observation, iso_time, usage_from_history

__all__ = ["InferReport", "infer_ontology"]


@dataclass(frozen=True, slots=True, kw_only=True)
class InferReport:
    """What the inference saw: messages read, types found, invalid types left out."""

    messages: int
    types: int
    invalid: tuple[tuple[str, int], ...] = ()


@dataclass(slots=True)
class _Draft:
    segment: str
    children: dict[str, _Draft] = field(default_factory=dict)
    observation: Observation | None = None


def _insert(roots: dict[str, _Draft], obs: Observation) -> None:
    level = roots
    draft: _Draft | None = None
    for segment in obs.type.split("."):
        draft = level.setdefault(ascii_fold(segment), _Draft(segment=segment))
        level = draft.children
    assert draft is not None  # a valid type has at least one segment
    draft.observation = obs


def _content(msg: Message) -> tuple[str, ContentSpec | None]:
    """Return the example content (XML re-indented) and what it says about the content."""
    if not msg.content_is_xml:
        return msg.content, (ContentSpec(language=msg.language) if msg.language else None)
    try:
        roots = parse_fragment(msg.content)
        text = indent_xml(msg.content)
    except OpenAIRError:
        return msg.content, None
    root = local_name(roots[0]) if len(roots) == 1 else ""
    return text, ContentSpec(language=msg.language or "xml", root=root)


def _example(obs: Observation) -> tuple[tuple[Example, ...], ContentSpec | None]:
    msg = obs.example
    if msg is None:
        return (), None
    content, spec = _content(msg)
    when = msg.received or msg.posted
    example = Example(
        title=f"Observed {iso_time(when)}" if when else "Observed",
        sender=msg.sender,
        to=msg.stored or msg.to,
        language=msg.language,
        content=content,
        is_xml=msg.content_is_xml and spec is not None,
    )
    return (example,), spec


def _name_ok(name: str) -> bool:
    return bool(name) and name_problem(name) is None


def _node(draft: _Draft) -> TypeNode:
    children = tuple(_node(c) for _, c in sorted(draft.children.items()))
    obs = draft.observation
    if obs is None:
        return TypeNode(segment=draft.segment, children=children)
    examples, content = _example(obs)
    # Only names an ontology can hold (OA-SESS-30); a history may carry any `from` text.
    posters = [(m, wb if _name_ok(wb) else "") for m, wb, _ in obs.posters if _name_ok(m)]
    boards = tuple(dict.fromkeys(wb for _, wb in posters if wb))
    return TypeNode(
        segment=draft.segment,
        kind=Kind.MESSAGE,
        content=content,
        examples=examples,
        posters=tuple(dict.fromkeys(Link(module=m, whiteboard=wb) for m, wb in posters)),
        observed=Observed(
            count=obs.count,
            first=iso_time(obs.first) if obs.first else "",
            last=iso_time(obs.last) if obs.last else "",
            whiteboards=boards,
        ),
        children=children,
    )


def infer_ontology(
    messages: Sequence[Message], *, name: str, source: str = ""
) -> tuple[Ontology, InferReport]:
    """Return a skeleton ontology of every valid type in `messages`, and a report."""
    usage = usage_from_history(messages)
    roots: dict[str, _Draft] = {}
    for obs in usage.observations:
        _insert(roots, obs)
    where = f" from {source}" if source else ""
    description = (
        f"Skeleton inferred{where}: {len(messages)} messages of {len(usage.observations)} "
        "types. Describe each type, mark the groups, and add namespaces, families and "
        "deprecations."
    )
    ontology = Ontology(
        name=name,
        version="0",
        description=description,
        types=tuple(_node(d) for _, d in sorted(roots.items())),
    )
    report = InferReport(
        messages=len(messages), types=len(usage.observations), invalid=usage.invalid_types
    )
    return ontology, report
