"""AIR.Retrieve and AIR.Retrieves (spec 9), and the retrieves of a registration (OA-WAKE-7).

The criteria themselves are evaluated by `Whiteboard.retrieve`; this module reads the request,
chooses the whiteboard of each retrieve (OA-RET-2) and builds the reply (OA-RET-7, OA-RET-12,
OA-RET-15).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from openair.protocol.attachments import chunks_of
from openair.protocol.content import RetrieveSpec
from openair.protocol.errors import (
    LimitExceededError,
    OpenAIRError,
    RetrieveInvalidError,
    WhiteboardUnknownError,
)
from openair.protocol.fastcodec import fast_encode_str
from openair.protocol.framing import Wire
from openair.protocol.message import Message
from openair.protocol.objects import parse_content
from openair.protocol.registration import parse_retrieve_element, parse_retrieves
from openair.protocol.wakeup import PeekedCopies, collection_parts, encoded_groups, frame_header
from openair.protocol.xmlsafe import local_name
from openair.server.core.commands import error_reply, reply
from openair.server.core.whiteboard import Whiteboard, select, text_bytes

__all__ = [
    "RETRIEVE",
    "RETRIEVES",
    "PreparedRetrieve",
    "answer_retrieve",
    "parse_request",
    "prepare_retrieve",
    "registration_results",
]

RETRIEVE = "AIR.Retrieve"
RETRIEVES = "AIR.Retrieves"
# The envelope around the collection in a reply: type, ids, names and times; generous.
_ENVELOPE_ALLOWANCE = 1024
# Retrieves that scan at least this many stored copies are chosen and written on a worker.
_LARGE_SCAN = 2048
#: Where the collection goes in the envelope written around it (`<` is escaped in every slot).
_SPLICE = "<openair-splice/>"


def parse_request(msg: Message) -> tuple[RetrieveSpec, ...]:
    """Read the retrieves of an AIR.Retrieve (one `<retrieve>`) or AIR.Retrieves (`<retrieves>`).

    Text content is read as the XML it spells (OA-RET-14). RETRIEVE_INVALID for empty or
    unparsable content or the wrong element (OA-RET-10); PATTERN_INVALID for a bad `type`.
    """
    wanted = "retrieves" if msg.type == RETRIEVES else "retrieve"
    roots = parse_content(msg.content, RetrieveInvalidError)
    if len(roots) != 1 or local_name(roots[0]) != wanted:  # OA-RET-10
        found = ", ".join(f"<{local_name(r)}>" for r in roots) or "empty content"
        raise RetrieveInvalidError(f"{msg.type} needs one <{wanted}>, found {found}")
    if wanted == "retrieve":
        return (parse_retrieve_element(roots[0]),)
    return parse_retrieves(msg.content)


def answer_retrieve(
    msg: Message,
    addressee: Whiteboard,
    whiteboards: Mapping[str, Whiteboard],
    *,
    now_ns: int,
    max_xml: int,
    max_binary: int = 64 * 1024 * 1024,
) -> Message:
    """Answer an AIR.Retrieve / AIR.Retrieves sent to `addressee` (spec 9.1–9.4).

    The results' attachments travel as the reply's chunks (OA-RET-19); a reply whose XML or
    chunks would exceed the limits is LIMIT_EXCEEDED (OA-RET-15).
    """
    prepared = prepare_retrieve(
        msg, addressee, whiteboards, now_ns=now_ns, max_xml=max_xml, max_binary=max_binary
    )
    return prepared.build()[0]


@dataclass(frozen=True, slots=True)
class PreparedRetrieve:
    """The results of a retrieve, chosen; its reply is built by `build`, on any thread.

    Choosing reads the whiteboards, so it happens where they live (the event loop); writing a
    reply of thousands of messages takes a second, so a server does it on a worker thread while
    other clients are served (issue #19, item 6). The results are immutable stored copies.
    """

    request: Message
    sender: str
    now_ns: int
    # Each retrieve with the stored copies of its whiteboard when the request came (a snapshot:
    # the scan reads it on a worker thread while the loop stores and evicts).
    scans: tuple[tuple[RetrieveSpec, tuple[Message, ...]], ...] = ()
    error: OpenAIRError | None = None
    max_xml: int = 0
    max_binary: int = 0
    # Where a worker thread reads the stored copies' XML (the router's cache) and the pause
    # it makes between pieces of the work (issue #19); None: encoded here, no pause.
    copies: PeekedCopies | None = None

    @property
    def large(self) -> bool:
        """Whether choosing and writing the results is worth a worker thread."""
        return self.error is None and sum(len(copies) for _, copies in self.scans) >= _LARGE_SCAN

    def results(self) -> list[Message]:
        """Choose the results: OA-RET-12, in the order of the retrieves, each newest first.

        The scan stops once the results alone pass max-frame-xml: such a reply is refused
        anyway (OA-RET-15), and a huge board must not be read to its end (issue #19).
        """
        results: list[Message] = []
        for spec, copies in self.scans:
            results.extend(
                select(copies, spec, now_ns=self.now_ns, max_bytes=self.max_xml, pause=self._pause)
            )
            if sum(text_bytes(m) for m in results) > self.max_xml:
                raise LimitExceededError(
                    f"the results exceed max-frame-xml ({self.max_xml} bytes);"
                    " ask for fewer with latest"
                )
        return results

    def build(self, *, text: bool = True) -> tuple[Message, Wire | None]:
        """Return the reply and its Message frame, as parts (None: the sender encodes it).

        The frame is written in parts of about 256 KiB, the collection's pieces encoded a group
        at a time: on a worker thread no single operation on megabytes holds the interpreter
        lock the event loop waits for (issue #19). Joined, the parts are the frame `to_frame`
        and `encode_frame` make of the reply. With `text=False` a reply that comes with its
        frame carries an empty content: the frame is what is sent, and joining the collection
        into one string of megabytes would hold the lock for milliseconds.
        """
        base = RETRIEVES if self.request.type == RETRIEVES else RETRIEVE
        try:
            pieces, chunks = self._content()
        except OpenAIRError as err:
            failed = error_reply(
                self.request, err, sender=self.sender, now_ns=self.now_ns, type_=f"{base}.Failed"
            )
            return failed, None

        def answer(content: str) -> Message:
            return reply(
                self.request,
                f"{base}.Success",
                sender=self.sender,
                now_ns=self.now_ns,
                content=content,
                xml=True,
            )

        if chunks:
            return dataclasses.replace(answer("".join(pieces)), binary=chunks), None
        # The collection is the canonical text lxml writes, so it is spliced in as it is: the
        # envelope is written around a placeholder no escaped slot can contain.
        spliced = answer(_SPLICE)
        envelope = fast_encode_str(spliced, xml_content=True)
        if envelope is None:
            return answer("".join(pieces)), None
        head, _, tail = envelope.partition(_SPLICE)
        groups = encoded_groups(pieces, pause=self._pause)
        parts = [head.encode("utf-8"), *groups, tail.encode("utf-8")]
        wire = (frame_header(sum(map(len, parts))), *parts)
        # The reply is the one written (its id): its content, checked above, put in place.
        return spliced.trusted_replace(content="".join(pieces) if text else ""), wire

    @property
    def _pause(self) -> Callable[[], None] | None:
        return self.copies.pause if self.copies is not None else None

    def _content(self) -> tuple[list[str], tuple[bytes, ...]]:
        if self.error is not None:
            raise self.error
        results = self.results()
        pieces = collection_parts(results, self.copies)  # OA-RET-7: encode_message_collection
        size = sum(len(p) if p.isascii() else len(p.encode("utf-8")) for p in pieces)
        if size + _ENVELOPE_ALLOWANCE > self.max_xml:  # OA-RET-15
            raise LimitExceededError(
                f"{len(results)} results exceed max-frame-xml ({self.max_xml} bytes)"
            )
        chunks = chunks_of(results)  # OA-RET-19, OA-MSG-21: in the order of the results
        if sum(len(chunk) for chunk in chunks) > self.max_binary:  # OA-RET-15
            raise LimitExceededError(
                f"the attachments of {len(results)} results exceed max-frame-binary"
                f" ({self.max_binary} bytes); ask for fewer with latest"
            )
        return pieces, chunks


def prepare_retrieve(
    msg: Message,
    addressee: Whiteboard,
    whiteboards: Mapping[str, Whiteboard],
    *,
    now_ns: int,
    max_xml: int,
    max_binary: int = 64 * 1024 * 1024,
    before_read: Callable[[Whiteboard], None] | None = None,
) -> PreparedRetrieve:
    """Read an AIR.Retrieve / AIR.Retrieves (spec 9.1–9.4) and take what its retrieves scan.

    Cheap on the loop: the request is parsed and each whiteboard's copies are snapshot; the
    scan and the writing happen in `build`, wherever it runs. `before_read` is called once
    for every whiteboard the retrieves read, before its snapshot (a cluster node catches up
    with the copies other nodes stored, OA-CLU-3).
    """
    prepared = PreparedRetrieve(
        request=msg, sender=addressee.name, now_ns=now_ns, max_xml=max_xml, max_binary=max_binary
    )
    snapshots: dict[str, tuple[Message, ...]] = {}
    scans: list[tuple[RetrieveSpec, tuple[Message, ...]]] = []
    try:
        for spec in parse_request(msg):  # OA-RET-12: concatenated in the order of the retrieves
            board = whiteboards.get(spec.whiteboard or addressee.name)  # OA-RET-2, OA-WB-10
            if board is None:
                raise WhiteboardUnknownError(spec.whiteboard)  # OA-RET-11
            if board.name not in snapshots:
                if before_read is not None:
                    before_read(board)
                snapshots[board.name] = board.snapshot()
            scans.append((spec, snapshots[board.name]))
    except OpenAIRError as err:
        return dataclasses.replace(prepared, error=err)
    return dataclasses.replace(prepared, scans=tuple(scans))


def registration_results(
    retrieves: Sequence[RetrieveSpec],
    trigger_board: Whiteboard,
    whiteboards: Mapping[str, Whiteboard],
    *,
    now_ns: int,
    max_count: int = 0,
    max_bytes: int = 0,
) -> list[Message]:
    """Evaluate a woken module's retrieves at decision time (OA-WAKE-7, OA-WAKE-3).

    A retrieve without `from` reads the whiteboard that stored the trigger message; one whose
    `from` names no whiteboard adds nothing (OA-REG-9). All the retrieves together give at most
    `max_count` messages whose text slots hold at most `max_bytes` (OA-LIM-9; 0 = no bound):
    the first results in the order of the retrieves, newest first within each, and no scan goes
    past the bound.
    """
    results: list[Message] = []
    size = 0
    for spec in retrieves:
        board = whiteboards.get(spec.whiteboard) if spec.whiteboard else trigger_board
        if board is None:
            continue
        room = max_count - len(results) if max_count else 0
        budget = max_bytes - size if max_bytes else 0
        found = board.retrieve(spec, now_ns=now_ns, limit=room, max_bytes=budget)
        for msg in found:
            size += text_bytes(msg)
            if max_bytes and size > max_bytes:
                return results  # OA-LIM-9: this one and the rest do not fit
            results.append(msg)
        if max_count and len(results) >= max_count:
            break
    return results
