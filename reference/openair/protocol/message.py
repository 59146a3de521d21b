"""The OpenAIR message envelope as a value (spec section 3).

`Message` is immutable; build variants with `dataclasses.replace` or the helpers below. The XML
form lives in `codec.py`; this module knows nothing of XML. Slot names follow the canonical
spelling; `from` is a Python keyword, so the field is `sender`.
"""

from __future__ import annotations

import operator
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

from openair.protocol.times import AirTime

DEFAULT_PRIORITY = 2.0  # OA-MSG-6, OA-PRIO-3
MIN_PRIORITY = 0.0
MAX_PRIORITY = 6.999

#: Canonical order of the known slots (DESIGN-NOTES: canonical XML). `content` is last.
CANONICAL_SLOTS: tuple[str, ...] = (
    "type",
    "id",
    "from",
    "to",
    "cc",
    "stored",
    "isresponse",
    "inreplyto",
    "postedTime",
    "receivedTime",
    "comment",
    "history",
    "wbid",
    "netprotocol",
    "binarysizes",
    "totalbinarysize",
    "content",
)


def new_id() -> str:
    """Return a fresh message id (a random UUID, OA-MSG-8)."""
    return str(uuid.uuid4())


@dataclass(frozen=True, slots=True, kw_only=True)
class Reference:
    """A `<reference>` to another message (used by `inreplyto` and `history`)."""

    id: str
    stored: str = ""
    type: str = ""
    sender: str = ""
    to: str = ""
    cc: str = ""
    time: AirTime | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Slot:
    """An extension slot kept verbatim (OA-MSG-5): its name and its text or inner XML."""

    name: str
    value: str = ""
    is_xml: bool = False


@dataclass(frozen=True, slots=True, kw_only=True)
class Message:
    """One OpenAIR message.

    `content` is text when `content_is_xml` is false, otherwise the serialized inner XML of the
    `<content>` element (zero or more elements, OA-MSG-10). `priority=None` means the slot was
    absent (effective priority 2.0). `binary` holds the chunks that travel after the XML
    (OA-FRAME-4); the codec writes `binarysizes` from them. `history` keeps the raw inner XML of
    the slot.
    """

    type: str
    id: str = field(default_factory=new_id)
    sender: str = ""
    to: str = ""
    cc: str = ""
    stored: str = ""
    isresponse: str = ""
    inreplyto: Reference | None = None
    posted: AirTime | None = None
    received: AirTime | None = None
    priority: float | None = None
    timetolive: float | None = None
    noreply: bool = False
    language: str = ""
    content: str = ""
    content_is_xml: bool = False
    content_version: str = ""  # the `version` attribute of `content` (OA-MSG-22)
    comment: str = ""
    history: str = ""
    wbid: int | None = None
    netprotocol: str = ""
    extras: tuple[Slot, ...] = ()
    binary: tuple[bytes, ...] = ()

    def __post_init__(self) -> None:
        # OA-MSG-6: priority is 0.0 (highest) to 6.999 (lowest).
        if self.priority is not None and not MIN_PRIORITY <= self.priority <= MAX_PRIORITY:
            raise ValueError(f"priority out of range 0.0-6.999: {self.priority}")
        if self.wbid is not None and self.wbid < 0:
            raise ValueError(f"wbid must not be negative: {self.wbid}")

    @property
    def effective_priority(self) -> float:
        """The priority used for ordering: the slot's value, or 2.0 when absent (OA-PRIO-3)."""
        return DEFAULT_PRIORITY if self.priority is None else self.priority

    @property
    def cc_names(self) -> tuple[str, ...]:
        """The module names in `cc`: `;`-separated, whitespace around names ignored (OA-CC-1)."""
        return tuple(name for name in (part.strip() for part in self.cc.split(";")) if name)

    def extra(self, name: str) -> Slot | None:
        """Return the extension slot called `name` (case-insensitive, OA-MSG-3), if any."""
        folded = name.casefold()
        for slot in self.extras:
            if slot.name.casefold() == folded:
                return slot
        return None

    def with_extra(self, name: str, value: str, *, is_xml: bool = False) -> Message:
        """Return a copy with the extension slot `name` set (replacing one of the same name)."""
        kept = tuple(s for s in self.extras if s.name.casefold() != name.casefold())
        return replace(self, extras=(*kept, Slot(name=name, value=value, is_xml=is_xml)))

    @classmethod
    def trusted(cls, **values: Any) -> Message:
        """Build a Message of values that were validated already: no `__init__`, no checks.

        The TRUSTED CONSTRUCTOR. Omitted fields take their defaults (`id` is "" here, not a new
        id). Nothing is checked — not the priority range (OA-MSG-6), not `wbid` — so use it only
        where the values are known good, as it is used today: the fast decoder after its
        patterns matched (`fastcodec`), replies the server core builds from fields it read
        (`server.core.commands`, `server.core.streamservice`), stored copies and wakeups built
        from a decoded message (`server.core.whiteboard`, `wakeup`), and the cluster store.
        Anything built from user input goes through `Message(...)`.
        """
        row = list(_DEFAULTS)
        for name, value in values.items():
            row[_AT[name]] = value
        return _from_row(row)

    def trusted_replace(self, **changes: Any) -> Message:
        """Return a copy with `changes`, as `dataclasses.replace` does, unchecked (`trusted`)."""
        row = list(_values(self))
        for name, value in changes.items():
            row[_AT[name]] = value
        return _from_row(row)

    @classmethod
    def trusted_row(cls, row: Sequence[Any]) -> Message:
        """Build a Message from all its values in field order, unchecked (see `trusted`)."""
        return _from_row(row)

    def reference(self) -> Reference:
        """Return a `<reference>` to this message (for `inreplyto`)."""
        return Reference(
            id=self.id,
            stored=self.stored,
            type=self.type,
            sender=self.sender,
            to=self.to,
            cc=self.cc,
            time=self.posted,
        )

    def reply(
        self,
        type: str,
        *,
        sender: str,
        content: str = "",
        content_is_xml: bool = False,
        language: str = "",
    ) -> Message:
        """Build a reply to this request: `isresponse` = this id, addressed to the requester."""
        return Message(
            type=type,
            sender=sender,
            to=self.sender,
            isresponse=self.id,  # OA-SESS-1
            content=content,
            content_is_xml=content_is_xml,
            language="xml" if content_is_xml and not language else language,
        )


# -- the trusted constructor's machinery ---------------------------------------------------------
#
# Setting 23 slots through a frozen dataclass costs ~12 µs per message (its `__init__` calls
# `object.__setattr__` per field, then `__post_init__`); one descriptor call per slot still costs
# ~2.5 µs. `_Fields` is Message's slot layout without the frozen `__setattr__`: `_fill` stores
# every slot with one unpacking assignment (plain slot stores, ~0.6 µs in all), then the object
# is given its class — allowed because the layouts are identical, which is checked below.


class _Fields:
    """Message's slots, writable: filled by `_fill`, then made a Message (trusted values only)."""

    __slots__ = (  # noqa: RUF023 (field order, as `_fill` stores them)
        "type", "id", "sender", "to", "cc", "stored", "isresponse", "inreplyto", "posted",
        "received", "priority", "timetolive", "noreply", "language", "content",
        "content_is_xml", "content_version", "comment", "history", "wbid", "netprotocol",
        "extras", "binary",
    )  # fmt: skip


def _fill(m: Any, v: Sequence[Any]) -> None:
    (
        m.type, m.id, m.sender, m.to, m.cc, m.stored, m.isresponse, m.inreplyto, m.posted,
        m.received, m.priority, m.timetolive, m.noreply, m.language, m.content,
        m.content_is_xml, m.content_version, m.comment, m.history, m.wbid, m.netprotocol,
        m.extras, m.binary,
    ) = v  # fmt: skip


def _from_row(row: Sequence[Any]) -> Message:
    msg: Any = _Fields()
    _fill(msg, row)
    msg.__class__ = Message  # same layout (checked below): the object becomes the Message
    return msg  # type: ignore[no-any-return]


FIELDS: tuple[str, ...] = tuple(f.name for f in fields(Message))
if not FIELDS == Message.__slots__ == _Fields.__slots__:
    raise RuntimeError("Message's fields, its slots and _Fields differ")  # _fill relies on them
_AT = {name: i for i, name in enumerate(FIELDS)}
_values = operator.attrgetter(*FIELDS)  # all of a message's values, in field order
_DEFAULTS: tuple[Any, ...] = _values(Message(type="", id=""))
