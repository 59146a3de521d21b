"""Attachments: the binary chunks of stored copies nested in content (spec 3.4, OA-MSG-21).

A post's chunks stay with its stored copy (OA-WB-13). When stored copies travel inside another
message (a wakeup's TriggerMessage and RetrievedMessages, a retrieve reply's results), their
chunks become the chunks of the outer frame, in document order of the nested copies; each copy's
own `binarysizes` says how many of them are its own. Sans-I/O.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence

from lxml import etree

from openair.protocol.errors import ContentInvalidError
from openair.protocol.message import Message
from openair.protocol.objects import parse_root, read_message_collection
from openair.protocol.xmlsafe import local_name

__all__ = [
    "ChunkCursor",
    "attach_collection",
    "chunks_of",
    "parse_results",
    "prefix_within",
    "total_size",
]


def chunks_of(messages: Iterable[Message]) -> tuple[bytes, ...]:
    """Return the chunks of `messages` in order: what the outer frame carries (OA-MSG-21)."""
    return tuple(chunk for msg in messages for chunk in msg.binary)


def total_size(msg: Message) -> int:
    """Return the bytes of a message's attachments."""
    return sum(len(chunk) for chunk in msg.binary)


def prefix_within(messages: Sequence[Message], budget: int) -> int:
    """Return how many of `messages`, from the first, fit in `budget` attachment bytes.

    Used to leave retrieved messages out of a wakeup from the end (OA-WAKE-11).
    """
    used = 0
    for count, msg in enumerate(messages):
        used += total_size(msg)
        if used > budget:
            return count
    return len(messages)


def _sizes(el: etree._Element) -> tuple[int, ...]:
    """Return the sizes the `binarysizes` child of a nested `<message>` lists (any case)."""
    slots = [
        child
        for child in el
        if isinstance(child.tag, str) and local_name(child).lower() == "binarysizes"
    ]
    if not slots:
        return ()
    if len(slots) > 1:
        raise ContentInvalidError("a nested message has more than one binarysizes slot")
    text = (slots[0].text or "").strip()
    if not text:
        return ()
    sizes: list[int] = []
    for part in text.split(","):
        digits = part.strip()
        if not digits.isascii() or not digits.isdigit() or len(digits) > 12:
            raise ContentInvalidError(f"nested binarysizes {text[:40]!r} is not a size list")
        sizes.append(int(digits))
    return tuple(sizes)


class ChunkCursor:
    """Hand the chunks of an outer frame to its nested messages in document order (OA-MSG-21).

    A mismatch (too few or too many chunks, a size that differs) is CONTENT_INVALID.
    """

    def __init__(self, chunks: Sequence[bytes]) -> None:
        self._chunks = chunks
        self._next = 0

    def __repr__(self) -> str:
        return f"<ChunkCursor {self._next} of {len(self._chunks)} chunks taken>"

    def take(self, el: etree._Element) -> tuple[bytes, ...]:
        """Return the chunks of the nested `<message>` element `el`."""
        sizes = _sizes(el)
        end = self._next + len(sizes)
        if end > len(self._chunks):
            raise ContentInvalidError(
                f"nested messages list more chunks than the {len(self._chunks)} the frame carries"
            )
        taken = tuple(self._chunks[self._next : end])
        for size, chunk in zip(sizes, taken, strict=True):
            if len(chunk) != size:
                raise ContentInvalidError(
                    f"chunk {self._next + 1} has {len(chunk)} bytes, its message lists {size}"
                )
        self._next = end
        return taken

    def attach(self, msg: Message, el: etree._Element) -> Message:
        """Return `msg` (read from `el`) with its chunks."""
        chunks = self.take(el)
        return dataclasses.replace(msg, binary=chunks) if chunks else msg

    def finish(self) -> None:
        """Raise CONTENT_INVALID when chunks are left that no nested message listed."""
        if self._next != len(self._chunks):
            left = len(self._chunks) - self._next
            raise ContentInvalidError(f"{left} chunk(s) of the frame belong to no nested message")


def _message_elements(collection: etree._Element) -> list[etree._Element]:
    return [
        inner
        for obj in collection
        if isinstance(obj.tag, str)
        for inner in obj
        if isinstance(inner.tag, str)
    ]


def attach_collection(
    messages: Sequence[Message], collection: etree._Element, cursor: ChunkCursor
) -> tuple[Message, ...]:
    """Give each message read from `<objectcollection>` its chunks from `cursor`."""
    elements = _message_elements(collection)
    if len(elements) != len(messages):  # read_message_collection checked the shape already
        raise ContentInvalidError("the collection and its messages disagree")
    return tuple(cursor.attach(msg, el) for msg, el in zip(messages, elements, strict=True))


def parse_results(reply: Message) -> tuple[Message, ...]:
    """Read a retrieve reply's results with their attachments (OA-RET-7, OA-RET-19)."""
    collection = parse_root(reply.content, ("objectcollection",), ContentInvalidError)
    messages = read_message_collection(collection)
    cursor = ChunkCursor(reply.binary)
    attached = attach_collection(messages, collection, cursor)
    cursor.finish()
    return attached
