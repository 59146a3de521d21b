"""A wakeup's parts as the router decides them, written now or later on a worker (spec 8.6).

The router decides on its own thread everything a wakeup says that depends on state: the
trigger (the stored copy), the retrieved messages (OA-WAKE-7: the registrations and the
whiteboards *now*), the PhaseSpec, the id and postedTime. What is left is writing text: the
stored copy's XML, the collection, the content and the frame. For a wakeup of megabytes (a
megabyte post, a thousand retrieved messages) that writing held the event loop for 5-11 ms, so
every other client waited (issue #19). `WakeupParts` keeps the decided parts; `build()` writes
them — the same text and bytes as writing them at once, since only immutable stored copies
and strings go in — and may run on a worker thread: it reads the router's cache of encoded
copies and never writes it. A deferred delivery carries a `preview` instead of the wakeup
until then: the envelope and the PhaseSpec without the trigger or retrieved messages, what
an observer that keeps deliveries needs (the wakeup's id, its lasttrigger), a few hundred bytes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from openair.protocol.framing import Wire
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.wakeup import (
    EncodedCopies,
    PeekedCopies,
    assemble_wakeup,
    collection_xml,
)
from openair.server.core.whiteboard import text_bytes

__all__ = ["LARGE_WAKEUP", "TriggerXml", "WakeupParts"]

#: A wakeup whose text slots pass this many bytes is written off the router's thread when the
#: adapter asks for it (`Router.defer_large_wakeups`): ~1.3 ms of writing at most on the loop.
LARGE_WAKEUP = 256 * 1024


class TriggerXml:
    """The XML of one stored copy, written once for every wakeup it triggers (OA-WAKE-3)."""

    __slots__ = ("_text", "size", "stored")

    def __init__(self, stored: Message) -> None:
        self.stored = stored
        self.size = text_bytes(stored)  # a lower bound of its XML
        self._text: str | None = None

    def now(self, copies: EncodedCopies) -> str:
        """On the router's thread: through the router's cache (a later retrieve finds it)."""
        if self._text is None:
            self._text = copies.xml(self.stored)
        return self._text

    def later(self, copies: EncodedCopies) -> str:
        """On a worker: from the cache when it holds it, else written here and remembered."""
        if self._text is None:
            self._text = PeekedCopies(copies).xml(self.stored)
        return self._text


@dataclass(slots=True, kw_only=True)  # not frozen: built per delivery, frozen costs 2x
class WakeupParts:
    """Everything decided about one wakeup; `write`/`build` turn it into text and a frame.

    Never changed once made (a build may read it on another thread).
    """

    trigger: TriggerXml
    retrieved: Sequence[Message]
    phase_xml: str
    whiteboard: str
    module: str
    id: str
    posted: AirTime
    copies: EncodedCopies = field(repr=False)

    @property
    def size(self) -> int:
        """A lower bound of the wakeup's text: its trigger's and retrieved messages' slots."""
        retrieved = self.retrieved
        return self.trigger.size + (sum(map(text_bytes, retrieved)) if retrieved else 0)

    def write(self) -> tuple[Message, Wire | None]:
        """Write the wakeup on the router's thread (filling the router's cache)."""
        return self._assemble(
            self.trigger.now(self.copies), collection_xml(self.retrieved, self.copies)
        )

    def build(self) -> tuple[Message, Wire | None]:
        """Write the wakeup on a worker thread: the same message and frame as `write()`.

        With the cache's `pause` (the server's worker) the frame comes in parts, encoded a
        piece at a time with a pause before each (issue #19).
        """
        peeked = PeekedCopies(self.copies)
        trigger_xml = self.trigger.later(self.copies)
        return self._assemble(
            trigger_xml, collection_xml(self.retrieved, peeked), self.copies.pause
        )

    def preview(self) -> Message:
        """The wakeup without its trigger or retrieved messages: envelope, id and PhaseSpec."""
        return self._assemble("", collection_xml(()))[0]

    def _assemble(
        self, trigger_xml: str, retrieved_xml: str, pause: Callable[[], None] | None = None
    ) -> tuple[Message, Wire | None]:
        return assemble_wakeup(
            trigger_xml=trigger_xml,
            retrieved_xml=retrieved_xml,
            phase_xml=self.phase_xml,
            whiteboard=self.whiteboard,
            module=self.module,
            id=self.id,
            posted=self.posted,
            pause=pause,
        )
