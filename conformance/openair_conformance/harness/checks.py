"""Independent readers of what the server sends, for cases to check (the suite is the judge).

`wakeup_view` takes an `AIR.Instruct.Wakeup` apart without trusting the reference's own
`openair.protocol.wakeup` reader, so that a shared bug cannot make both agree: object names and
their order (OA-WAKE-1), the trigger message (OA-WAKE-2), the retrieved messages (OA-WAKE-3) and the
`<phase>` attributes (OA-WAKE-4); likewise retrieve results and other content objects. Names
of content-object elements and attributes are compared case-insensitively (OA-MSG-3).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from lxml import etree

from openair.protocol.codec import message_from_element
from openair.protocol.message import Message

__all__ = [
    "WakeupUnreadable",
    "WakeupView",
    "attributes",
    "content_object",
    "content_root",
    "is_phase_update",
    "message_collection",
    "registered_module_name",
    "triggered_by",
    "wakeup_trigger_id",
    "wakeup_view",
]

_PARSER = etree.XMLParser(
    resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_blank_text=True
)


class WakeupUnreadable(ValueError):
    """A server message's content is not the object the spec requires (wakeup, collection…)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class WakeupView:
    """A wakeup taken apart: object names in order, the messages, the phase attributes."""

    objects: tuple[str, ...]
    trigger: Message | None
    retrieved: tuple[Message, ...]
    has_collection: bool
    phase: tuple[tuple[str, str], ...] | None  # attributes of <phase>, names lower-cased
    phase_trigger_count: int = 0

    def phase_attr(self, name: str) -> str | None:
        """Return a `<phase>` attribute (case-insensitive name), or None."""
        if self.phase is None:
            return None
        return dict(self.phase).get(name.lower())


def _local(el: etree._Element) -> str:
    return etree.QName(el).localname.lower() if isinstance(el.tag, str) else ""


def content_root(msg: Message) -> list[etree._Element]:
    """Parse a message's XML content into its top-level elements (WakeupUnreadable if bad)."""
    try:
        wrapper = etree.fromstring(f"<c>{msg.content}</c>".encode(), _PARSER)
    except etree.XMLSyntaxError as exc:
        raise WakeupUnreadable(f"content is not XML: {exc}") from exc
    return [el for el in wrapper if isinstance(el.tag, str)]


def _attrs(el: etree._Element) -> tuple[tuple[str, str], ...]:
    return tuple((_text(k).lower(), _text(v)) for k, v in el.attrib.items())


def _text(value: str | bytes) -> str:
    return value.decode() if isinstance(value, bytes) else value


def _messages_in(collection: etree._Element) -> tuple[Message, ...]:
    found = []
    for obj in collection:
        if _local(obj) != "object":
            continue
        for child in obj:
            if _local(child) == "message":
                found.append(message_from_element(child))
    return tuple(found)


def content_object(msg: Message, tag: str) -> etree._Element:
    """Return the single top-level element `tag` of a message's content (any language).

    Text content is parsed too: a legacy peer may send an object as escaped text. Raises
    WakeupUnreadable when the content is not exactly one such element.
    """
    roots = content_root(msg)
    if len(roots) != 1 or _local(roots[0]) != tag.lower():
        found = [_local(r) for r in roots]
        raise WakeupUnreadable(f"content must be one <{tag}>, found {found or 'nothing'}")
    return roots[0]


def attributes(el: etree._Element) -> dict[str, str]:
    """Return an element's attributes with lower-cased names (OA-MSG-3)."""
    return dict(_attrs(el))


def message_collection(msg: Message) -> tuple[Message, ...]:
    """Return the messages of an `<objectcollection>` content (retrieve replies, OA-RET-7)."""
    collection = content_object(msg, "objectcollection")
    try:
        return _messages_in(collection)
    except Exception as exc:  # the codec's errors: an unreadable stored copy
        raise WakeupUnreadable(f"a message in the collection is unreadable: {exc}") from exc


def _objects(dictionary: etree._Element) -> list[tuple[str, etree._Element | None]]:
    """Return (name, first child element) for each `<object>` of an objectdictionary."""
    found: list[tuple[str, etree._Element | None]] = []
    for obj in dictionary:
        if _local(obj) != "object":
            continue
        children = [c for c in obj if isinstance(c.tag, str)]
        found.append((attributes(obj).get("name", ""), children[0] if children else None))
    return found


def _phase_triggers(phase: etree._Element) -> int:
    return sum(1 for g in phase if _local(g) == "triggers" for t in g if _local(t) == "trigger")


def wakeup_view(msg: Message) -> WakeupView:
    """Take a wakeup apart; WakeupUnreadable when its content is not an objectdictionary."""
    objects = _objects(content_object(msg, "objectdictionary"))
    parts: dict[str, etree._Element | None] = {}
    for name, first in objects:
        parts.setdefault(name, first)
    trigger_el = parts.get("TriggerMessage")
    collection = parts.get("RetrievedMessages")
    phase_el = parts.get("PhaseSpec")
    has_collection = collection is not None and _local(collection) == "objectcollection"
    try:
        trigger = (
            message_from_element(trigger_el)
            if trigger_el is not None and _local(trigger_el) == "message"
            else None
        )
        retrieved = _messages_in(collection) if has_collection and collection is not None else ()
    except Exception as exc:  # the codec's errors: the server sent an unreadable message
        raise WakeupUnreadable(f"a message in the wakeup is unreadable: {exc}") from exc
    is_phase = phase_el is not None and _local(phase_el) == "phase"
    return WakeupView(
        objects=tuple(name for name, _ in objects),
        trigger=trigger,
        retrieved=retrieved,
        has_collection=has_collection,
        phase=_attrs(phase_el) if is_phase and phase_el is not None else None,
        phase_trigger_count=_phase_triggers(phase_el) if is_phase and phase_el is not None else 0,
    )


def is_phase_update(msg: Message) -> bool:
    """Return whether a wakeup is a phase update (no TriggerMessage object, OA-WAKE-8)."""
    if msg.type != "AIR.Instruct.Wakeup":
        return False
    try:
        return "TriggerMessage" not in wakeup_view(msg).objects
    except WakeupUnreadable:
        return False  # unreadable: keep it with the wakeups, where a case will judge it


def wakeup_trigger_id(msg: Message) -> str | None:
    """Return the id of the wakeup's trigger message, or None if it has none.

    When the trigger message cannot be read as a whole (a legacy server echoes a posted
    priority 6.999 as "7.00", or spells other slots its own way), its `<id>` is read directly:
    recognising a message the suite sent (a barrier sentinel) must not depend on the decoder
    accepting every other slot.
    """
    try:
        trigger = wakeup_view(msg).trigger
    except WakeupUnreadable:
        return _raw_trigger_id(msg)
    return trigger.id if trigger is not None else None


def _raw_trigger_id(msg: Message) -> str | None:
    """Return the text of the TriggerMessage's `<id>`, read from the element tree, or None."""
    try:
        objects = _objects(content_object(msg, "objectdictionary"))
    except WakeupUnreadable:
        return None
    trigger = next((el for name, el in objects if name == "TriggerMessage"), None)
    if trigger is None or _local(trigger) != "message":
        return None
    ident = next((c for c in trigger if _local(c) == "id"), None)
    return (ident.text or "").strip() if ident is not None else None


def triggered_by(message_id: str) -> Callable[[Message], bool]:
    """Return a predicate: the wakeup's TriggerMessage has this id."""

    def predicate(msg: Message) -> bool:
        return wakeup_trigger_id(msg) == message_id

    return predicate


def registered_module_name(content_xml: str) -> str | None:
    """Return N of a registration whose content is `<module name="N">`, else None."""
    try:
        roots = content_root(Message(type="", content=content_xml))
    except WakeupUnreadable:
        return None
    if len(roots) != 1 or _local(roots[0]) != "module":
        return None
    return attributes(roots[0]).get("name")
