"""Mutants of reading input (spec sections 2, 3, 4 and 13): frames and message validity.

Frame mutants replace the `FrameReader` and `encode_frame` that `openair.server.aio.protocol`
imports (the harness reads frames with its own reference to the real ones) or wrap
`ServerConnection`. Validity mutants make the server's decoder lenient: when
`openair.server.aio.responder.from_frame` refuses a message MESSAGE_INVALID, a `fix` edits the XML
and the message is decoded again, so a message the spec refuses is accepted.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from lxml import etree
from mutants_core import Fn, child, mutant, wrap

from openair.protocol.errors import MessageInvalidError, RemoteProtocolError
from openair.protocol.framing import Frame, FrameReader, FrameTag
from openair.protocol.message import Message
from openair.protocol.xmlsafe import local_name, parse_xml
from openair.server.aio import delivery, protocol, responder, writer

# --- frames (2.1, 2.2) ---------------------------------------------------------------------------


def _reader_patch(mp: pytest.MonkeyPatch, feed: Callable[[FrameReader, bytes, Fn], None]) -> None:
    """Make the server's frame readers call `feed(reader, data, original_feed)`."""
    original = FrameReader.feed

    class FaultyReader(FrameReader):
        def feed(self, data: bytes | bytearray | memoryview) -> None:
            feed(self, bytes(data), lambda d: original(self, d))

    mp.setattr(protocol, "FrameReader", FaultyReader)


@mutant("frame-tag-any-case", "frame tags are read in any case", "OA-FRAME-2")
def _tag_case(mp: pytest.MonkeyPatch) -> None:
    def feed(reader: FrameReader, data: bytes, original: Fn) -> None:
        for wrong in (b"message\0", b"MESSAGE\0", b"receive\0", b"RECEIVE\0"):
            data = data.replace(wrong, wrong.capitalize())
        original(data)

    _reader_patch(mp, feed)


@mutant("split-frame-dropped", "bytes that continue an unfinished frame are lost", "OA-FRAME-11")
def _split_dropped(mp: pytest.MonkeyPatch) -> None:
    def feed(reader: FrameReader, data: bytes, original: Fn) -> None:
        if not reader.in_frame:
            original(data)

    _reader_patch(mp, feed)


@mutant("unknown-tag-answered", "a bad frame header is answered before the close", "OA-FRAME-6")
def _bad_header_answered(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _framing_error(self: Any, exc: RemoteProtocolError) -> None:
            if exc.reply or self.role is not protocol.Role.RESPONDER:
                original(self, exc)
                return
            self.send(writer.error_reply(self.name, "RECEIVE_ERROR", exc.wire_text()))
            self.close()

        return _framing_error

    wrap(mp, protocol.ServerConnection, "_framing_error", make)


@mutant("framing-error-closes-all", "a framing error closes every client connection", "OA-ERR-4")
def _closes_all(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _framing_error(self: Any, exc: RemoteProtocolError) -> None:
            original(self, exc)
            for conn in list(self.host._conns.values()):
                conn.close()

        return _framing_error

    wrap(mp, protocol.ServerConnection, "_framing_error", make)


@mutant("length-in-characters", "reply frames give the XML length in characters", "OA-FRAME-3")
def _length_in_chars(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def encode_frame(frame: Frame) -> bytes:
            data: bytes = original(frame)
            if frame.tag is FrameTag.BINARY:
                return data
            chars = len(frame.xml.decode("utf-8", "replace"))
            return data[:8] + chars.to_bytes(4, "little") + data[12:]

        return encode_frame

    wrap(mp, writer, "encode_frame", make)


# --- message validity (3.1, 3.2, 4) --------------------------------------------------------------


def _lenient(mp: pytest.MonkeyPatch, fix: Callable[[etree._Element], bool]) -> None:
    """Decode again, after `fix` edited the XML, what the server refuses MESSAGE_INVALID."""

    def make(original: Fn) -> Fn:
        def decode(frame: Frame, limits: Any = None) -> Message:
            try:
                result: Message = original(frame, limits)
                return result
            except MessageInvalidError:
                root = parse_xml(frame.xml)
                if not fix(root):
                    raise
            xml = etree.tostring(root, encoding="UTF-8")
            fixed: Message = original(Frame(tag=frame.tag, xml=xml, chunks=frame.chunks), limits)
            return fixed

        return decode

    wrap(mp, responder, "from_frame", make)


def _children(root: etree._Element, name: str) -> list[etree._Element]:
    return [c for c in root if isinstance(c.tag, str) and local_name(c) == name]


@mutant("priority-range-unchecked", "a priority out of 0-6.999 is ignored", "OA-MSG-6")
def _priority_unchecked(mp: pytest.MonkeyPatch) -> None:
    def fix(root: etree._Element) -> bool:
        names = [k for k in root.attrib if str(k).lower() == "priority"]
        for name in names:
            del root.attrib[name]
        for el in _children(root, "priority"):
            root.remove(el)
        return bool(names) or False

    _lenient(mp, fix)


@mutant("duplicate-slot-accepted", "a known slot given twice is read once", "OA-MSG-16")
def _duplicate_slot(mp: pytest.MonkeyPatch) -> None:
    def fix(root: etree._Element) -> bool:
        seen: set[str] = set()
        changed = False
        for el in list(root):
            name = local_name(el) if isinstance(el.tag, str) else ""
            if name and name in seen:
                root.remove(el)
                changed = True
            seen.add(name)
        return changed

    _lenient(mp, fix)


@mutant("untyped-message-accepted", "a message without a type is read as Untyped", "OA-MSG-2")
def _untyped(mp: pytest.MonkeyPatch) -> None:
    def fix(root: etree._Element) -> bool:
        found = child(root, "type")
        if found is not None and (found.text or "").strip():
            return False
        if found is None:
            found = etree.Element("type")
            root.insert(0, found)
        found.text = "Untyped"
        return True

    _lenient(mp, fix)


@mutant("bad-posted-time-dropped", "an invalid postedTime is dropped, not refused", "OA-TIME-6")
def _bad_time(mp: pytest.MonkeyPatch) -> None:
    def fix(root: etree._Element) -> bool:
        found = _children(root, "postedtime") + _children(root, "posted_time")
        for el in found:
            root.remove(el)
        return bool(found)

    _lenient(mp, fix)


@mutant("inreplyto-first-reference", "inreplyto with two references keeps the first", "OA-MSG-11")
def _inreplyto(mp: pytest.MonkeyPatch) -> None:
    def fix(root: etree._Element) -> bool:
        slot = child(root, "inreplyto")
        refs = _children(slot, "reference") if slot is not None else []
        for extra in refs[1:]:
            slot.remove(extra)  # type: ignore[union-attr]
        return len(refs) > 1

    _lenient(mp, fix)


# --- extension wire forms (1.2) ------------------------------------------------------------------


@mutant("noreply-to-legacy", "noreply is delivered to modules that did not declare it", "OA-GEN-2")
def _noreply_to_legacy(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(delivery.ModuleDelivery, "_wire_form", lambda self, msg: msg)
