"""What a system does with its types: who posts, who subscribes, which streams, what was seen.

`usage_from_config` reads a loaded psySpec (`openair.protocol.psyspec.load_config`): the modules'
triggers and retrieves (their registrations, spec 8.2), the `<post>` declarations (which the
server echoes but does not interpret, spec 12.1), the whiteboards and their streams, and the
modules' stream references. `usage_from_history` reads recorded messages (stored copies): who
posted each type to which whiteboard, how often, when, and the latest content. `merge` joins
the two.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime

from lxml import etree

from openair.protocol.matching import ascii_fold
from openair.protocol.message import Message
from openair.protocol.psyspec import ServerConfig
from openair.protocol.times import AirTime
from openair.protocol.types import is_valid_type
from openair.protocol.xmlsafe import XmlLimits, parse_xml

__all__ = [
    "ModuleInfo",
    "Observation",
    "Posting",
    "Source",
    "StreamDecl",
    "Subscription",
    "Usage",
    "WhiteboardInfo",
    "iso_time",
    "merge",
    "usage_from_config",
    "usage_from_history",
]


class Source(enum.Enum):
    """Where a fact about a type comes from."""

    PSYSPEC = "psySpec"
    HISTORY = "history"
    ONTOLOGY = "ontology"


@dataclass(frozen=True, slots=True, kw_only=True)
class Subscription:
    """A trigger or retrieve pattern of one module's phase (`whiteboard` "" = any)."""

    module: str
    pattern: str
    whiteboard: str = ""
    kind: str = "trigger"  # "trigger" | "retrieve"
    phase: str = ""
    context: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Posting:
    """A module posts `type` to `whiteboard`; `count` is how often the history saw it."""

    module: str
    type: str
    whiteboard: str = ""
    source: Source = Source.PSYSPEC
    count: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamDecl:
    """A stream of a whiteboard (spec 11.1), its type (11.7, "" if untyped), readers, writers."""

    name: str
    whiteboard: str
    type: str = ""
    readers: tuple[str, ...] = ()
    writers: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class ModuleInfo:
    """A module of the psySpec."""

    name: str
    description: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class WhiteboardInfo:
    """A whiteboard of the psySpec."""

    name: str
    description: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class Observation:
    """One type as a history showed it: count, first/last time, posters, latest content."""

    type: str
    count: int
    first: AirTime | None = None
    last: AirTime | None = None
    posters: tuple[tuple[str, str, int], ...] = ()  # (module, whiteboard, count), most first
    example: Message | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Usage:
    """Everything known about how the system uses its types."""

    system: str = ""
    modules: tuple[ModuleInfo, ...] = ()
    whiteboards: tuple[WhiteboardInfo, ...] = ()
    subscriptions: tuple[Subscription, ...] = ()
    postings: tuple[Posting, ...] = ()
    streams: tuple[StreamDecl, ...] = ()
    observations: tuple[Observation, ...] = ()
    invalid_types: tuple[tuple[str, int], ...] = ()  # history types that are not valid types
    has_psyspec: bool = False
    has_history: bool = False

    def module(self, name: str) -> ModuleInfo | None:
        return next((m for m in self.modules if m.name == name), None)

    def patterns(self) -> list[str]:
        """Return the distinct subscription patterns, in first-seen order."""
        return list(dict.fromkeys(s.pattern for s in self.subscriptions))

    def posted_types(self) -> list[str]:
        """Return the distinct posted types (psySpec and history), in first-seen order."""
        return list(dict.fromkeys(p.type for p in self.postings))


def iso_time(t: AirTime) -> str:
    """Return a time as an xs:dateTime in UTC with milliseconds (`2026-11-22T10:00:00.123Z`)."""
    moment = datetime.fromtimestamp(t.ms / 1000, tz=UTC)
    return moment.isoformat(timespec="milliseconds").replace("+00:00", "Z")


# --------------------------------------------------------------------------------------------
# psySpec
# --------------------------------------------------------------------------------------------


def usage_from_config(config: ServerConfig) -> Usage:
    """Return the usage a psySpec declares: subscriptions, posts, streams, descriptions."""
    modules: list[ModuleInfo] = []
    subscriptions: list[Subscription] = []
    postings: list[Posting] = []
    for module in config.modules:
        el = _module_element(module.spec_xml)
        modules.append(ModuleInfo(name=module.name, description=_description(el)))
        for phase in module.registration.phases:
            where = {"module": module.name, "phase": phase.name, "context": phase.context}
            subscriptions.extend(
                Subscription(pattern=t.pattern, whiteboard=t.whiteboard, **where)
                for t in phase.triggers
            )
            subscriptions.extend(
                Subscription(pattern=r.pattern, whiteboard=r.whiteboard, kind="retrieve", **where)
                for r in phase.retrieves
                if r.pattern
            )
        postings.extend(_posts(module.name, el))
    return Usage(
        system=config.name,
        modules=tuple(modules),
        whiteboards=_whiteboards(config),
        subscriptions=tuple(subscriptions),
        postings=tuple(dict.fromkeys(postings)),
        streams=_streams(config),
        has_psyspec=True,
    )


def _module_element(spec_xml: str) -> etree._Element:
    """Parse the `<module>` XML the configuration kept (already validated; hardened anyway)."""
    data = spec_xml.encode("utf-8")
    return parse_xml(data, XmlLimits(max_bytes=max(len(data), 1)))


def _description(el: etree._Element) -> str:
    found = next((c for c in el if c.tag == "description"), None)
    return " ".join((found.text or "").split()) if found is not None else ""


def _posts(module: str, el: etree._Element) -> list[Posting]:
    """Read every `<post type to>`, with `to` inherited from an enclosing `<posts to>`."""
    found: list[Posting] = []
    for post in el.iter("post"):
        type_ = post.get("type", "")
        if not type_:
            continue
        parent = post.getparent()
        group_to = parent.get("to", "") if parent is not None and parent.tag == "posts" else ""
        found.append(Posting(module=module, type=type_, whiteboard=post.get("to") or group_to))
    return found


def _whiteboards(config: ServerConfig) -> tuple[WhiteboardInfo, ...]:
    """Return the whiteboards with the descriptions of the psySpec file, when it can be read."""
    descriptions: dict[str, str] = {}
    if config.source:
        try:
            with open(config.source, "rb") as f:
                root = parse_xml(f.read(), XmlLimits(max_bytes=64 * 1024 * 1024))
            descriptions = {
                el.get("name", ""): _description(el) for el in root if el.tag == "whiteboard"
            }
        except Exception:  # descriptions are decoration; load_config already judged the file
            descriptions = {}
    return tuple(
        WhiteboardInfo(name=wb.name, description=descriptions.get(wb.name, ""))
        for wb in config.whiteboards
    )


def _streams(config: ServerConfig) -> tuple[StreamDecl, ...]:
    """Return the streams with their types (OA-XSTREAM-1) and the modules that use them."""
    users: dict[str, tuple[list[str], list[str]]] = {}
    decls: list[StreamDecl] = []
    for wb in config.whiteboards:
        for stream in wb.streams:
            type_ = dict(stream.attributes).get("type", "")
            decls.append(StreamDecl(name=stream.name, whiteboard=wb.name, type=type_))
            users[stream.name] = users[ascii_fold(type_) or stream.name] = ([], [])
    for module in config.modules:
        for phase in module.registration.phases:
            for ref in phase.streams:
                # A typed stream is addressable by its type as well as by its name (OA-XSTREAM-1).
                pair = users.get(ref.source) or users.get(ascii_fold(ref.source))
                if pair is not None:
                    pair[1 if ref.kind == "outputstream" else 0].append(module.name)
    return tuple(
        replace(
            d,
            readers=tuple(dict.fromkeys(users[d.name][0])),
            writers=tuple(dict.fromkeys(users[d.name][1])),
        )
        for d in decls
    )


# --------------------------------------------------------------------------------------------
# History
# --------------------------------------------------------------------------------------------


@dataclass(slots=True)
class _Tally:
    count: int = 0
    first: AirTime | None = None
    last: AirTime | None = None
    posters: dict[tuple[str, str], int] = field(default_factory=dict)
    example: Message | None = None


def _time(msg: Message) -> AirTime | None:
    return msg.received or msg.posted


def _add(tally: _Tally, msg: Message) -> None:
    tally.count += 1
    t = _time(msg)
    if t is not None:
        tally.first = t if tally.first is None else min(tally.first, t)
        if tally.last is None or t >= tally.last:
            tally.last = t
            if msg.content:
                tally.example = msg
    elif msg.content and tally.example is None:
        tally.example = msg
    key = (msg.sender, msg.stored or msg.to)
    tally.posters[key] = tally.posters.get(key, 0) + 1


def usage_from_history(messages: Iterable[Message]) -> Usage:
    """Return who posted which type where, how often and when, from stored copies."""
    tallies: dict[str, _Tally] = {}
    names: dict[str, str] = {}  # folded type -> first spelling seen
    invalid: dict[str, int] = {}
    for msg in messages:
        if not is_valid_type(msg.type):  # Psyclone stores some invalid types (DEV-5)
            invalid[msg.type] = invalid.get(msg.type, 0) + 1
            continue
        folded = ascii_fold(msg.type)
        names.setdefault(folded, msg.type)
        _add(tallies.setdefault(folded, _Tally()), msg)
    observations = tuple(_observation(names[k], t) for k, t in tallies.items())
    postings = tuple(
        Posting(module=module, type=o.type, whiteboard=wb, source=Source.HISTORY, count=n)
        for o in observations
        for module, wb, n in o.posters
    )
    return Usage(
        postings=postings,
        observations=observations,
        invalid_types=tuple(invalid.items()),
        has_history=True,
    )


def _observation(type_: str, tally: _Tally) -> Observation:
    posters = sorted(tally.posters.items(), key=lambda item: (-item[1], item[0]))
    return Observation(
        type=type_,
        count=tally.count,
        first=tally.first,
        last=tally.last,
        posters=tuple((module, wb, n) for (module, wb), n in posters),
        example=tally.example,
    )


def merge(usages: Sequence[Usage]) -> Usage:
    """Join several usages (a psySpec and histories); observations of one type are summed."""
    if not usages:
        return Usage()
    return Usage(
        system=next((u.system for u in usages if u.system), ""),
        modules=tuple(m for u in usages for m in u.modules),
        whiteboards=tuple(w for u in usages for w in u.whiteboards),
        subscriptions=tuple(s for u in usages for s in u.subscriptions),
        postings=tuple(p for u in usages for p in u.postings),
        streams=tuple(s for u in usages for s in u.streams),
        observations=_merge_observations([o for u in usages for o in u.observations]),
        invalid_types=tuple(i for u in usages for i in u.invalid_types),
        has_psyspec=any(u.has_psyspec for u in usages),
        has_history=any(u.has_history for u in usages),
    )


def _merge_observations(observations: list[Observation]) -> tuple[Observation, ...]:
    by_type: dict[str, Observation] = {}
    for obs in observations:
        key = ascii_fold(obs.type)
        old = by_type.get(key)
        by_type[key] = obs if old is None else _join(old, obs)
    return tuple(by_type.values())


def _join(a: Observation, b: Observation) -> Observation:
    firsts = [t for t in (a.first, b.first) if t is not None]
    lasts = [t for t in (a.last, b.last) if t is not None]
    later = b if (b.last or AirTime(sec=0)) >= (a.last or AirTime(sec=0)) else a
    return Observation(
        type=a.type,
        count=a.count + b.count,
        first=min(firsts) if firsts else None,
        last=max(lasts) if lasts else None,
        posters=a.posters + b.posters,
        example=later.example or a.example or b.example,
    )
