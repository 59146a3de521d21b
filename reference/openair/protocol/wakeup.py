"""The `AIR.Instruct.Wakeup` delivery (spec 8.7) and the phase update (spec 8.8).

`build_wakeup` makes the message a whiteboard sends to a woken module; with no trigger message
it makes the phase update that `ContextsAndPhases` sends. `parse_wakeup` reads both, whether
this kit or Psyclone 1.1.7 wrote them (Psyclone's stored copies put `netprotocol` and `wbid`
before `postedTime`; its PhaseSpec carries `pid`, `currentcontexts` and `activationtime`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from lxml import etree

from openair.protocol._errors_base import OpenAIRError
from openair.protocol.attachments import ChunkCursor, attach_collection, chunks_of, prefix_within
from openair.protocol.codec import message_from_element, message_to_element
from openair.protocol.content import Phase
from openair.protocol.errors import ContentInvalidError, MessageInvalidError
from openair.protocol.fastcodec import (
    fast_encode_str,
    text_slot_xml,
    time_xml,
)
from openair.protocol.framing import Frame, FrameTag, Wire, encode_frame
from openair.protocol.message import Message, Slot
from openair.protocol.objects import (
    attr,
    element,
    elements,
    message_collection_element,
    parse_content,
    read_message_collection,
    serialize,
    single_child,
)
from openair.protocol.registration import phase_spec_element, read_phase
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import local_name

__all__ = [
    "WAKEUP_TYPE",
    "EncodedCopies",
    "PeekedCopies",
    "Wakeup",
    "assemble_wakeup",
    "attach_wakeup",
    "build_wakeup",
    "collection_xml",
    "fit_attachments",
    "parse_wakeup",
    "phase_spec_xml",
    "stored_xml",
]

WAKEUP_TYPE = "AIR.Instruct.Wakeup"
TRIGGER_MESSAGE = "TriggerMessage"
RETRIEVED_MESSAGES = "RetrievedMessages"
PHASE_SPEC = "PhaseSpec"
OMITTED = "omitted"  # the slot of OA-WAKE-11


@dataclass(frozen=True, slots=True, kw_only=True)
class Wakeup:
    """A wakeup taken apart: the stored trigger message, the retrieved messages and the phase.

    `trigger` is None for a phase update (OA-WAKE-8); `phase` is None when the wakeup carries
    no PhaseSpec ("out of context", spec 8.8). `lasttrigger` is the pattern that fired, empty
    for a wakeup due only to `cc` (OA-WAKE-4). Messages carry their attachments in `binary`
    (OA-WAKE-10); `omitted` counts the retrieved messages the server left out so that the
    attachments fit its frame limit (the `omitted` slot, OA-WAKE-11).
    """

    trigger: Message | None
    retrieved: tuple[Message, ...] = ()
    phase: Phase | None = None
    lasttrigger: str = ""
    omitted: int = 0


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


# --- the fast writer: the same content and bytes as build_wakeup, spliced from cached parts ---

_EMPTY_COLLECTION = "<objectcollection/>"  # what lxml writes for an empty collection
_TRIGGER_OPEN = f'<objectdictionary><object name="{TRIGGER_MESSAGE}">'
_RETRIEVED_OPEN = f'</object><object name="{RETRIEVED_MESSAGES}">'
_PHASE_OPEN = f'</object><object name="{PHASE_SPEC}">'
_CLOSE = "</object></objectdictionary>"


def stored_xml(msg: Message) -> str:
    """Return `msg` as XML text exactly as it appears inside a wakeup (canonical form)."""
    fast = fast_encode_str(msg)
    return fast if fast is not None else serialize(message_to_element(msg))


class EncodedCopies:
    """Remember the XML of recently encoded stored copies, by identity (bounded).

    A stored copy is immutable, so its XML never changes; a registration that retrieves the
    latest messages finds the copies encoded when they were posted. The cache belongs to one
    thread (the router's); another thread reads it with `peek` and hands what it had to encode
    back with `offer`, which the owner keeps at its next `settle` (issue #19: a wakeup of a
    thousand retrieved copies built on the worker thread encoded all of them again every time).
    `pause`, when the adapter sets it, is called by such a reader before each copy it reads.
    """

    #: Called by a `PeekedCopies` reader before each copy (the server's worker lets the
    #: interpreter lock go there now and then, issue #19); None: nothing.
    pause: Callable[[], None] | None

    def __init__(self, size: int = 1024, max_bytes: int = 16 << 20) -> None:
        self._size = size
        self._max_bytes = max_bytes  # XML kept at most (issue #19: large posts)
        self._bytes = 0
        self._xml: dict[int, tuple[Message, str]] = {}
        #: Encoded on another thread, not kept yet: `deque.append` and `popleft` are atomic.
        self._offered: deque[tuple[Message, str]] = deque()
        # Their cost as `_keep` counts it: added by the offering thread only, taken by the
        # owner's only (no lock: each counter has one writer).
        self._offered_in = 0
        self._offered_out = 0
        self.pause = None

    def peek(self, msg: Message) -> str | None:
        """Return the cached XML of `msg`, or None; it never changes the cache.

        One dict look-up: safe on a worker thread while the owner's thread adds and evicts
        (a deferred wakeup is built there, issue #19).
        """
        hit = self._xml.get(id(msg))
        return hit[1] if hit is not None and hit[0] is msg else None

    def offer(self, msg: Message, text: str) -> None:
        """Hand `stored_xml(msg)`, encoded on another thread, to the owner's next `settle`.

        Any thread. At most `size` wait, of at most the cache's `max_bytes`: more would be
        evicted by the next ones anyway.
        """
        cost = 2 * len(text)
        waiting = self._offered_in - self._offered_out
        if len(self._offered) < self._size and waiting + cost <= self._max_bytes:
            self._offered.append((msg, text))
            self._offered_in += cost

    def settle(self) -> None:
        """Keep what other threads offered (the owner's thread only)."""
        offered = self._offered
        while offered:
            msg, text = offered.popleft()
            self._offered_out += 2 * len(text)
            hit = self._xml.get(id(msg))
            if hit is None or hit[0] is not msg:
                self._keep(msg, text)

    def xml(self, msg: Message) -> str:
        """Return `stored_xml(msg)`, encoding it only once while it stays in the cache."""
        hit = self._xml.get(id(msg))
        if hit is not None and hit[0] is msg:
            return hit[1]
        text = stored_xml(msg)
        self._keep(msg, text)
        return text

    def _keep(self, msg: Message, text: str) -> None:
        # A copy is kept alive by the cache too: count it with its XML.
        cost = 2 * len(text)
        if cost > self._max_bytes:
            return  # never cached: it would push everything else out
        while self._xml and (len(self._xml) >= self._size or self._bytes + cost > self._max_bytes):
            oldest = next(iter(self._xml))
            self._bytes -= 2 * len(self._xml.pop(oldest)[1])  # the oldest entry
        self._xml[id(msg)] = (msg, text)  # the reference keeps id(msg) from being reused
        self._bytes += cost


class PeekedCopies:
    """`EncodedCopies` read from another thread: a hit is reused, a miss encoded and offered.

    Before each copy it calls the cache's `pause` (when set): the server's worker lets the
    interpreter lock go there now and then, so the event loop, which gives the lock up at each
    system call, does not wait a whole switch interval for it each time (issue #19).
    """

    def __init__(self, copies: EncodedCopies) -> None:
        self._copies = copies
        #: The cache's `pause` when this reader was made (None: nothing to call).
        self.pause = copies.pause

    def xml(self, msg: Message) -> str:
        """Return `stored_xml(msg)`, from the cache when it holds it."""
        if self.pause is not None:
            self.pause()
        hit = self._copies.peek(msg)
        if hit is not None:
            return hit
        text = stored_xml(msg)
        self._copies.offer(msg, text)
        return text


def collection_xml(
    msgs: Sequence[Message], copies: EncodedCopies | PeekedCopies | None = None
) -> str:
    """Return the RetrievedMessages `<objectcollection>` of `msgs` (OA-WAKE-3)."""
    if not msgs:
        return _EMPTY_COLLECTION
    encode = copies.xml if copies is not None else stored_xml
    inner = "".join(f"<object>{encode(m)}</object>" for m in msgs)
    return f"<objectcollection>{inner}</objectcollection>"


def collection_parts(
    msgs: Sequence[Message], copies: EncodedCopies | PeekedCopies | None = None
) -> list[str]:
    """Return `collection_xml(msgs)` as the pieces that joined make it: one per message."""
    if not msgs:
        return [_EMPTY_COLLECTION]
    encode = copies.xml if copies is not None else stored_xml
    return [
        "<objectcollection>",
        *(f"<object>{encode(m)}</object>" for m in msgs),
        "</objectcollection>",
    ]


def encoded_groups(
    pieces: Sequence[str],
    size: int = 256 * 1024,
    pause: Callable[[], None] | None = None,
) -> list[bytes]:
    """Return `pieces` encoded as UTF-8 in groups of about `size` characters.

    What a worker thread writes for a reply of megabytes: no single join or encode of the whole
    text, each of which holds the interpreter lock for milliseconds while the event loop waits
    for it (issue #19). `pause`, when given, is called before each group is encoded.
    """
    groups: list[bytes] = []
    group: list[str] = []
    held = 0
    for piece in pieces:
        group.append(piece)
        held += len(piece)
        if held >= size:
            if pause is not None:
                pause()
            groups.append("".join(group).encode("utf-8"))
            group, held = [], 0
    if group:
        groups.append("".join(group).encode("utf-8"))
    return groups


def frame_header(length: int) -> bytes:
    """Return the header of a Message frame whose XML is `length` bytes (OA-FRAME-1)."""
    return _MESSAGE_HEADER[:8] + length.to_bytes(4, "little")


def phase_spec_xml(phase: Phase | None, *, module: str, lasttrigger: str) -> str:
    """Return the PhaseSpec `<phase>` of a wakeup (OA-WAKE-4); callers may cache it."""
    return serialize(phase_spec_element(phase, module=module, lasttrigger=lasttrigger))


#: Characters of a wakeup encoded at a time when it is written in pieces (`assemble_wakeup`'s
#: `pause`): each piece is a block of the heap, not a fresh mapping to fault in, and encoding
#: it holds the interpreter lock some tens of microseconds, not a millisecond (issue #19).
PIECE_CHARS = 128 * 1024


def assemble_wakeup(
    *,
    trigger_xml: str,
    retrieved_xml: str,
    phase_xml: str,
    whiteboard: str,
    module: str,
    id: str,
    posted: AirTime,
    pause: Callable[[], None] | None = None,
) -> tuple[Message, Wire | None]:
    """Build the wakeup `build_wakeup` would (posted at `posted`) and its Message frame bytes.

    The parts are the outputs of `stored_xml`, `collection_xml` and `phase_spec_xml`, so the
    content is the text lxml would write; the frame is None when only the lxml writer can say
    whether the message can be written (then the sender encodes it as usual). With `pause`
    (a writer on another thread, issue #19) the frame is its parts, never joined: the content
    encoded `PIECE_CHARS` at a time, `pause()` called before each piece.
    """
    content = (
        f"{_TRIGGER_OPEN}{trigger_xml}{_RETRIEVED_OPEN}{retrieved_xml}"
        f"{_PHASE_OPEN}{phase_xml}{_CLOSE}"
    )
    msg = Message.trusted(
        type=WAKEUP_TYPE,
        id=id,
        sender=whiteboard,
        to=module,
        stored=whiteboard,
        posted=posted,
        language="xml",
        content=content,
        content_is_xml=True,
    )
    envelope = _envelope(whiteboard, module)
    id_xml = text_slot_xml("id", id)
    if envelope is None or id_xml is None:
        return msg, None  # only the lxml writer can say what is wrong
    head, middle = envelope
    before = f"{head}{id_xml}{middle}{time_xml('postedTime', posted)}{_CONTENT_OPEN}"
    if pause is not None:
        parts = [before.encode("utf-8")]
        for at in range(0, len(content), PIECE_CHARS):
            pause()
            parts.append(content[at : at + PIECE_CHARS].encode("utf-8"))
        parts.append(_END_BYTES)
        return msg, (frame_header(sum(map(len, parts))), *parts)
    # Encoded in pieces and joined once with the frame's header: a wakeup of megabytes is copied
    # twice here, not four times.
    pieces = (before.encode("utf-8"), content.encode("utf-8"), _END_BYTES)
    length = sum(map(len, pieces))
    return msg, b"".join((_MESSAGE_HEADER[:8], length.to_bytes(4, "little"), *pieces))


_CONTENT_OPEN = '<content language="xml">'
_END = "</content></message>"
_END_BYTES = _END.encode("ascii")
_ENVELOPES_MAX = 4096
_envelopes: dict[tuple[str, str], tuple[str, str] | None] = {}


def _envelope(whiteboard: str, module: str) -> tuple[str, str] | None:
    """Return the text of a wakeup around its id, and between id and postedTime (cached).

    Cut from what the canonical writer makes of a wakeup with an empty id and no time, so the
    spliced wakeup is the written one; None when the writer would leave it to lxml.
    """
    key = (whiteboard, module)
    if key in _envelopes:
        return _envelopes[key]
    probe = Message.trusted(
        type=WAKEUP_TYPE,
        id="",
        sender=whiteboard,
        to=module,
        stored=whiteboard,
        language="xml",
        content="<x/>",
        content_is_xml=True,
    )
    text = fast_encode_str(probe, xml_content=True)
    envelope = None
    if text is not None and text.endswith(f"{_CONTENT_OPEN}<x/>{_END}"):
        head, _, rest = text.partition("<id/>")
        envelope = head, rest[: -len(f"{_CONTENT_OPEN}<x/>{_END}")]
    if len(_envelopes) >= _ENVELOPES_MAX:
        _envelopes.clear()
    _envelopes[key] = envelope
    return envelope


_MESSAGE_HEADER = encode_frame(Frame(tag=FrameTag.MESSAGE))  # tag and a zero length


def frame_bytes(xml: bytes) -> bytes:
    """Return the Message frame of `xml` (OA-FRAME-1, OA-FRAME-3), as `encode_frame` would."""
    return _MESSAGE_HEADER[:8] + len(xml).to_bytes(4, "little") + xml


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
    trigger_el = objects.get(TRIGGER_MESSAGE)
    phase, lasttrigger = _phase(objects.get(PHASE_SPEC))
    trigger = _trigger(trigger_el)
    retrieved = () if retrieved_el is None else read_message_collection(retrieved_el)
    # OA-WAKE-10, OA-MSG-21: the frame's chunks are the trigger's, then the retrieved ones'.
    cursor = ChunkCursor(msg.binary)
    if trigger is not None and trigger_el is not None:
        trigger = cursor.attach(trigger, trigger_el)
    if retrieved_el is not None:
        retrieved = attach_collection(retrieved, retrieved_el, cursor)
    cursor.finish()
    return Wakeup(
        trigger=trigger,
        retrieved=retrieved,
        phase=phase,
        lasttrigger=lasttrigger,
        omitted=_omitted(msg),
    )


def _omitted(msg: Message) -> int:
    """Read the `omitted` slot of a wakeup (OA-WAKE-11); absent means 0."""
    slot = msg.extra(OMITTED)
    if slot is None:
        return 0
    text = slot.value.strip()
    if not text.isascii() or not text.isdigit():
        raise ContentInvalidError(f"omitted slot {text[:40]!r} is not a count")
    return int(text)


def fit_attachments(
    stored: Message, retrieved: Sequence[Message], max_binary: int
) -> tuple[Sequence[Message], int]:
    """Return the retrieved messages whose attachments fit a wakeup, and how many were left out.

    The trigger message's chunks always go (a post fits the same limit); retrieved messages
    are left out from the end of the collection until the total fits `max_binary`
    (OA-WAKE-11).
    """
    budget = max_binary - sum(len(chunk) for chunk in stored.binary)
    kept = prefix_within(retrieved, budget)
    return retrieved[:kept], len(retrieved) - kept


def attach_wakeup(
    wakeup: Message, stored: Message, retrieved: Sequence[Message], omitted: int
) -> Message:
    """Give a wakeup the chunks of its trigger and retrieved messages (OA-WAKE-10, OA-MSG-21).

    `omitted` > 0 adds the `omitted` slot (OA-WAKE-11).
    """
    chunks = chunks_of((stored, *retrieved))
    extras = (*wakeup.extras, Slot(name=OMITTED, value=str(omitted))) if omitted else wakeup.extras
    return wakeup.trusted_replace(binary=chunks, extras=extras)
