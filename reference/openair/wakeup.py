"""The `AIR.Instruct.Wakeup` delivery (spec 8.7) and the phase update (spec 8.8).

`build_wakeup` makes the message a whiteboard sends to a woken module; with no trigger message
it makes the phase update that `ContextsAndPhases` sends. `parse_wakeup` reads both, whether
this kit or Psyclone 1.1.7 wrote them (Psyclone's stored copies put `netprotocol` and `wbid`
before `postedTime`; its PhaseSpec carries `pid`, `currentcontexts` and `activationtime`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from lxml import etree

from openair._errors_base import OpenAIRError
from openair.codec import message_from_element, message_to_element
from openair.content import Phase
from openair.errors import ContentInvalidError, MessageInvalidError
from openair.message import Message
from openair.objects import (
    attr,
    element,
    elements,
    message_collection_element,
    parse_content,
    read_message_collection,
    serialize,
    single_child,
)
from openair.registration import phase_spec_element, read_phase
from openair.xmlsafe import local_name

__all__ = ["WAKEUP_TYPE", "Wakeup", "build_wakeup", "parse_wakeup"]

WAKEUP_TYPE = "AIR.Instruct.Wakeup"
TRIGGER_MESSAGE = "TriggerMessage"
RETRIEVED_MESSAGES = "RetrievedMessages"
PHASE_SPEC = "PhaseSpec"


@dataclass(frozen=True, slots=True, kw_only=True)
class Wakeup:
    """A wakeup taken apart: the stored trigger message, the retrieved messages and the phase.

    `trigger` is None for a phase update (OA-WAKE-8); `phase` is None when the wakeup carries
    no PhaseSpec ("out of context", spec 8.8). `lasttrigger` is the pattern that fired, empty
    for a wakeup due only to `cc` (OA-WAKE-4).
    """

    trigger: Message | None
    retrieved: tuple[Message, ...] = ()
    phase: Phase | None = None
    lasttrigger: str = ""


def _named_object(name: str, inner: etree._Element) -> etree._Element:
    obj = element("object", (("name", name),))
    obj.append(inner)
    return obj


def build_wakeup(
    *,
    stored: Message | None,
    whiteboard: str,
    module: str,
    retrieved: Sequence[Message] = (),
    phase: Phase | None = None,
    lasttrigger: str = "",
) -> Message:
    """Build the wakeup of spec 8.7, or a phase update (spec 8.8) when `stored` is None.

    A wakeup goes from the whiteboard to the module with `stored` = the whiteboard (OA-WAKE-1);
    its objectdictionary holds TriggerMessage (the stored copy, OA-WAKE-2), RetrievedMessages
    (OA-WAKE-3) and PhaseSpec (OA-WAKE-4; `phase` None is the empty default phase), in that
    order. A phase update comes from `whiteboard` (pass `ContextsAndPhases`), has an empty
    `stored` as Psyclone's do, and holds only PhaseSpec, or nothing when `phase` is None
    (OA-WAKE-9, OA-REG-15). `postedTime` is left for the sender to stamp (OA-TIME-2).
    """
    root = element("objectdictionary")
    if stored is not None:
        root.append(_named_object(TRIGGER_MESSAGE, message_to_element(stored)))
        root.append(_named_object(RETRIEVED_MESSAGES, message_collection_element(retrieved)))
    if stored is not None or phase is not None:
        spec = phase_spec_element(phase, module=module, lasttrigger=lasttrigger)
        root.append(_named_object(PHASE_SPEC, spec))
    return Message(
        type=WAKEUP_TYPE,
        sender=whiteboard,
        to=module,
        stored=whiteboard if stored is not None else "",
        language="xml",
        content=serialize(root),
        content_is_xml=True,
    )


def _objects(root: etree._Element) -> dict[str, etree._Element | None]:
    """Return the objects of an objectdictionary by name; an empty object maps to None."""
    found: dict[str, etree._Element | None] = {}
    for obj in elements(root):
        if local_name(obj) != "object":
            raise ContentInvalidError(f"<objectdictionary> holds <{local_name(obj)}>")
        name = attr(obj, "name")
        if name is None:
            raise ContentInvalidError("wakeup object without a name")
        if name in found:
            raise ContentInvalidError(f"wakeup object {name!r} appears twice")
        found[name] = single_child(obj, name, ContentInvalidError) if elements(obj) else None
    return found


def _trigger(el: etree._Element | None) -> Message | None:
    if el is None:
        return None
    if local_name(el) != "message":
        raise ContentInvalidError(f"{TRIGGER_MESSAGE} holds <{local_name(el)}>, not a message")
    try:
        return message_from_element(el)
    except MessageInvalidError as exc:
        raise ContentInvalidError(f"{TRIGGER_MESSAGE}: {exc.detail}") from None


def _phase(el: etree._Element | None) -> tuple[Phase | None, str]:
    if el is None:
        return None, ""
    if local_name(el) != "phase":
        raise ContentInvalidError(f"{PHASE_SPEC} holds <{local_name(el)}>, not a phase")
    try:
        return read_phase(el), attr(el, "lasttrigger") or ""
    except OpenAIRError as exc:
        raise ContentInvalidError(f"{PHASE_SPEC}: {exc.detail}") from None


def parse_wakeup(msg: Message) -> Wakeup:
    """Take an `AIR.Instruct.Wakeup` apart (spec 8.7, 8.8).

    Object names are matched exactly, the objects in any order; a missing TriggerMessage is a
    phase update (OA-WAKE-8), and empty content a phase update without a phase. Content that
    is not an objectdictionary, a TriggerMessage that is not a message, and the like are
    CONTENT_INVALID.
    """
    if msg.type != WAKEUP_TYPE:
        raise ContentInvalidError(f"{msg.type!r} is not {WAKEUP_TYPE}")
    roots = parse_content(msg.content, ContentInvalidError)
    if not roots:
        return Wakeup(trigger=None)
    if len(roots) != 1 or local_name(roots[0]) != "objectdictionary":
        found = ", ".join(f"<{local_name(r)}>" for r in roots)
        raise ContentInvalidError(f"wakeup content must be one <objectdictionary>, found {found}")
    objects = _objects(roots[0])
    retrieved_el = objects.get(RETRIEVED_MESSAGES)
    phase, lasttrigger = _phase(objects.get(PHASE_SPEC))
    return Wakeup(
        trigger=_trigger(objects.get(TRIGGER_MESSAGE)),
        retrieved=() if retrieved_el is None else read_message_collection(retrieved_el),
        phase=phase,
        lasttrigger=lasttrigger,
    )
