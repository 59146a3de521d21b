"""Write the frame test vectors: spec/vectors/frames/*.bin and manifest.json (spec section 2).

Usage: python tools/gen_frame_vectors.py [--check]

Every case is built here from literal data; the expected outcome of each case is written from
how the case was built, never by running a frame reader. `--check` rebuilds everything in
memory and exits 1 if a file in spec/vectors/frames differs, is missing or is left over.

The captured frames (tools/frame_captures.py) are copied from the Psyclone 1.1.7 wire
transcripts (psyclone-wire/, in the project's shared reference material; see
spec/vectors/frames/README.md).
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

TOOLS = Path(__file__).resolve().parent
ROOT = TOOLS.parent
OUT = ROOT / "spec" / "vectors" / "frames"
FORMAT = "openair-frame-vectors/1"
DEFAULT_LIMITS = {"max_xml": 16 * 1024 * 1024, "max_binary": 64 * 1024 * 1024}  # OA-LIM-1/2
WIRE = "psyclone-wire/"


def _load_captures() -> ModuleType:
    """Import the captured XML, tools/frame_captures.py, by path (tools/ is not a package)."""
    spec = importlib.util.spec_from_file_location("frame_captures", TOOLS / "frame_captures.py")
    assert spec is not None and spec.loader is not None, "tools/frame_captures.py not found"
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_CAPTURES = _load_captures()
RECORDED: dict[str, tuple[str, int]] = _CAPTURES.RECORDED  # name -> (literal, recorded xmllen)
R_E14_PARTIAL: str = _CAPTURES.R_E14_PARTIAL  # recorded xmllen 1000; only these bytes were sent

# -- building blocks ----------------------------------------------------------------------------

Desc = dict[str, Any]


def field8(tag: str) -> bytes:
    """Return the first 8 header bytes for a tag: NUL-padded to 7, then the NUL (OA-FRAME-1)."""
    return tag.encode("latin-1").ljust(7, b"\0") + b"\0"


def header(tag: str, length: int) -> bytes:
    return field8(tag) + struct.pack("<I", length)


def frame(tag: str, xml: bytes, *chunks: bytes) -> bytes:
    """Return a well-formed frame (BinaryM: `xml` is the one chunk)."""
    return header(tag, len(xml)) + xml + b"".join(chunks)


def desc(tag: str, xml: bytes, *chunks: bytes) -> Desc:
    """Return the manifest description of a frame a reader must deliver."""
    if tag == "BinaryM":
        xml, chunks = b"", (xml,)
    return {
        "tag": tag,
        "xml_len": len(xml),
        "xml_sha256": hashlib.sha256(xml).hexdigest(),
        "chunks": [len(c) for c in chunks],
        "chunks_sha256": [hashlib.sha256(c).hexdigest() for c in chunks],
    }


def ok(*frames: Desc) -> Desc:
    return {"frames": list(frames), "then": "ok"}


def truncated(*frames: Desc) -> Desc:
    return {"frames": list(frames), "then": "truncated"}


def error(name: str, error_by: int, *frames: Desc) -> Desc:
    return {
        "error": name,
        "after_frames": len(frames),
        "frames": list(frames),
        "error_by": error_by,
    }


def msg(type_: str, slots: str = "", content: str = "") -> bytes:
    """Return a small message's XML (UTF-8) with extra `slots` before its content."""
    return (
        f"<message><type>{type_}</type><from>VecWriter</from><to>WB1</to>{slots}"
        f'<content language="">{content}</content></message>'
    ).encode()


def sizes_xml(sizes: str, total: str | None = None, type_: str = "Vec.Binary") -> bytes:
    slot = f"<binarysizes>{sizes}</binarysizes>"
    if total is not None:
        slot += f"<totalbinarysize>{total}</totalbinarysize>"
    return msg(type_, slot)


def datasample(payload: bytes, **params: str) -> bytes:
    """Return a datasample chunk (spec 11.2, OA-STREAM-2)."""
    text = "%sep%".join(f"builtin:{k}%equals%{v}" for k, v in params.items())
    return struct.pack("<I", len(payload)) + payload + text.encode("ascii") + b"\0"


@dataclass
class Case:
    name: str
    data: bytes
    description: str
    requirements: list[str]
    expected: Desc
    source: str = "own"
    limits: dict[str, int] | None = field(default=None)

    def entry(self) -> Desc:
        out: Desc = {
            "name": self.name,
            "file": f"{self.name}.bin",
            "description": self.description,
            "requirements": self.requirements,
            "source": self.source,
        }
        if self.limits is not None:
            out["limits"] = self.limits
        out["expected"] = self.expected
        return out


F = ["OA-FRAME-1", "OA-FRAME-2", "OA-FRAME-3"]  # every well-formed Message/Receive frame
NEXT = msg("Vec.Next")  # a plain frame placed after a case's frame to show where it ended
NEXT_FRAME = frame("Message", NEXT)
NEXT_DESC = desc("Message", NEXT)


# fmt: off
# -- the cases (one Case per line group; kept compact by hand) ---------------------------------


def captured(name: str) -> bytes:
    """Return a captured literal as bytes, checking it against the recorded xmllen."""
    text, recorded = RECORDED[name]
    data = text.encode("utf-8")
    if len(data) != recorded:
        raise SystemExit(f"{name}: {len(data)} bytes, the transcript recorded {recorded}")
    return data


def captured_cases() -> list[Case]:
    bind, accept, note = captured("J_BIND"), captured("P_BIND_ACCEPT"), captured("J_RECEIVE_NAME")
    resolve = captured("P_RESOLVE_SUCCESS")
    get1, get2 = captured("J_GET_ENTRY_GLOBAL"), captured("J_GET_ENTRY_READER")
    entry1, entry2 = captured("P_ENTRY_GLOBAL"), captured("P_ENTRY_READER")
    e9, e11, e12 = captured("R_E9_MINIMAL"), captured("R_E11_MALFORMED"), captured("R_E12_HELLO")
    e13, e19, e20 = captured("R_E13_GARBAGE"), captured("R_E19_PING"), captured("R_E20_PING")
    e14 = R_E14_PARTIAL.encode()  # recorded xmllen 1000; only these bytes were sent
    big_endian = b"Message\0" + struct.pack(">I", len(e20)) + e20
    assert struct.unpack_from("<I", big_endian, 8)[0] == 570490880  # as the transcript decoded
    one, seven = "01-connect-bind.txt", "07-errors.txt"
    return [
        Case("captured-java-bind", frame("Message", bind),
             "JavaOpenAIR BIND (Reader -> CNS): lower-case postedtime, priority/timetolive "
             "attributes, XML ending in a newline; the header is the spec 2.1 example "
             "4d 65 73 73 61 67 65 00 20 01 00 00", F, ok(desc("Message", bind)),
             f"{WIRE}{one} +0.092s conn 1"),
        Case("captured-psyclone-bind-accept", frame("Message", accept),
             "Psyclone's BIND_ACCEPT: postedTime with two spaces and tzc, no trailing newline",
             F, ok(desc("Message", accept)), f"{WIRE}{one} +0.102s conn 1"),
        Case("captured-java-receive-notification", frame("Receive", note),
             "the Receive frame JavaOpenAIR sends on its callback connection",
             [*F, "OA-FRAME-10"], ok(desc("Receive", note)), f"{WIRE}{one} +0.108s conn 2"),
        Case("captured-psyclone-resolve-success", frame("Message", resolve),
             "Psyclone's RESOLVE_SUCCESS with a tcplocation in XML content", F,
             ok(desc("Message", resolve)), f"{WIRE}{one} +0.134s conn 1"),
        Case("captured-java-config-requests", frame("Message", get1) + frame("Message", get2),
             "everything JavaOpenAIR sent on its Config connection: two GET_ENTRY frames in one "
             "buffer", [*F, "OA-FRAME-11"], ok(desc("Message", get1), desc("Message", get2)),
             f"{WIRE}{one} +0.139s and +0.199s conn 3"),
        Case("captured-psyclone-config-replies",
             frame("Message", entry1) + frame("Message", entry2),
             "everything Psyclone sent on that Config connection: two ENTRY replies in one buffer",
             [*F, "OA-FRAME-11"], ok(desc("Message", entry1), desc("Message", entry2)),
             f"{WIRE}{one} +0.176s and +0.225s conn 3"),
        Case("captured-raw-minimal", frame("Message", e9),
             "probe E9: the minimal message <message><type>Raw.Min</type></message>", F,
             ok(desc("Message", e9)), f"{WIRE}{seven} +0.102s conn 2 (E9)"),
        Case("captured-raw-malformed-xml", frame("Message", e11),
             "probe E11: unterminated XML in a correct frame; framing succeeds (the XML error "
             "is the codec's, and the connection stays usable)", [*F, "OA-FRAME-13"],
             ok(desc("Message", e11)), f"{WIRE}{seven} +0.125s conn 2 (E11)"),
        Case("captured-raw-not-xml", frame("Message", e12),
             "probe E12: 'hello world' as the body of a Message frame; framing succeeds", F,
             ok(desc("Message", e12)), f"{WIRE}{seven} +0.160s conn 3 (E12)"),
        Case("captured-raw-garbage-tag", frame("Garbage", e13),
             "probe E13: tag 'Garbage', length 5, body 'hello'", ["OA-FRAME-2", "OA-FRAME-6"],
             error("FRAME_UNKNOWN_TAG", 8), f"{WIRE}{seven} +0.174s conn 4 (E13)"),
        Case("captured-raw-truncated-body", header("Message", 1000) + e14,
             "probe E14: the header announces 1000 bytes, then the stream ends after the 19 "
             "bytes the transcript prints", ["OA-FRAME-8"], truncated(),
             f"{WIRE}{seven} +5.177s conn 5 (E14)"),
        Case("captured-raw-lowercase-tag", frame("message", e19),
             "probe E19: tag 'message' (lower case) before a PING", ["OA-FRAME-2", "OA-FRAME-6"],
             error("FRAME_UNKNOWN_TAG", 8), f"{WIRE}{seven} +29.201s conn 9 (E19)"),
        Case("captured-raw-big-endian-length", big_endian,
             "probe E20: a PING whose length 290 was written big-endian, read as 570490880: "
             "refused from the header alone", ["OA-FRAME-1", "OA-FRAME-7", "OA-LIM-1"],
             error("FRAME_TOO_LARGE", 12), f"{WIRE}{seven} +34.207s conn 10 (E20)"),
        Case("captured-raw-bare-xml", captured("R_E16_BARE"),
             "probe E16: a PING's XML without any frame header", ["OA-FRAME-2", "OA-FRAME-6"],
             error("FRAME_UNKNOWN_TAG", 8), f"{WIRE}{seven} +21.185s conn 7 (E16, RAW)"),
    ]


def binary_cases() -> list[Case]:
    s1 = datasample(b"\x00\x01\x02\x03\xff", id="1", type="Binary")
    s2 = datasample(b"hello sample", id="2", duration="40")
    two = sizes_xml(f"{len(s1)},{len(s2)}", str(len(s1) + len(s2)), "Vec.Samples")
    recv = sizes_xml(str(len(s1)), str(len(s1)), "Vec.Receive")
    zeros = sizes_xml("0,4,0", "4")
    spaced = sizes_xml("\n 3 ,\t5 \n", " 8 ")
    cased = msg("Vec.Case", "<BinarySizes>2</BinarySizes><TOTALBINARYSIZE>2</TOTALBINARYSIZE>")
    zeroes = sizes_xml("003,0005", "08")
    no_total = sizes_xml("2,2")
    empty, blank = sizes_xml("", "0"), sizes_xml(" \n\t ")
    nested = (
        b"<message><type>Vec.Nested</type><content language=\"xml\">"
        b"<binarysizes>8</binarysizes></content></message>"
    )
    word = msg("Vec.Word", "", "binarysizes: 8")
    lone_total = msg("Vec.Total", "<totalbinarysize>7</totalbinarysize>")
    b4 = b"\x01\x02\x03\x04"
    req4 = [*F, "OA-FRAME-4"]
    return [
        Case("binary-two-datasample-chunks", frame("Message", two, s1, s2),
             "a message with two datasample chunks announced by binarysizes and totalbinarysize",
             [*req4, "OA-STREAM-2"], ok(desc("Message", two, s1, s2))),
        Case("binary-receive-with-chunk", frame("Receive", recv, s1),
             "chunks follow a Receive frame's XML as they follow a Message frame's", req4,
             ok(desc("Receive", recv, s1))),
        Case("binarym-datasample", frame("BinaryM", s2),
             "a BinaryM frame: L is the size of its one datasample chunk, no XML",
             ["OA-FRAME-1", "OA-FRAME-5"], ok(desc("BinaryM", s2))),
        Case("binarym-empty", frame("BinaryM", b""),
             "a BinaryM frame with L = 0 is well framed (the empty chunk is the stream "
             "layer's SAMPLE_INVALID)", ["OA-FRAME-5"], ok(desc("BinaryM", b""))),
        Case("binary-zero-length-chunks", frame("Message", zeros, b"", b4, b""),
             "binarysizes 0,4,0: zero-length chunks take no bytes", req4,
             ok(desc("Message", zeros, b"", b4, b""))),
        Case("binarysizes-whitespace", frame("Message", spaced, b"abc", b"defgh"),
             "whitespace around the numbers and the total is ignored", req4,
             ok(desc("Message", spaced, b"abc", b"defgh"))),
        Case("binarysizes-any-case", frame("Message", cased, b"xy"),
             "slot names compare case-insensitively: BinarySizes, TOTALBINARYSIZE", req4,
             ok(desc("Message", cased, b"xy"))),
        Case("binarysizes-leading-zeros", frame("Message", zeroes, b"abc", b"defgh"),
             "003,0005 with total 08: leading zeros are digits", req4,
             ok(desc("Message", zeroes, b"abc", b"defgh"))),
        Case("binarysizes-without-total", frame("Message", no_total, b"ab", b"cd"),
             "totalbinarysize is optional", req4, ok(desc("Message", no_total, b"ab", b"cd"))),
        Case("binarysizes-empty", frame("Message", empty) + NEXT_FRAME,
             "an empty binarysizes slot (total 0) announces no chunk: the next frame follows "
             "the XML at once", req4, ok(desc("Message", empty), NEXT_DESC)),
        Case("binarysizes-blank", frame("Message", blank) + NEXT_FRAME,
             "a binarysizes slot of whitespace only announces no chunk", req4,
             ok(desc("Message", blank), NEXT_DESC)),
        Case("binarysizes-nested-not-a-slot", frame("Message", nested) + NEXT_FRAME,
             "a binarysizes element inside content is not a slot (not a direct child of the "
             "root): no chunk", req4, ok(desc("Message", nested), NEXT_DESC)),
        Case("binarysizes-word-in-content", frame("Message", word) + NEXT_FRAME,
             "the word binarysizes in content text announces nothing", req4,
             ok(desc("Message", word), NEXT_DESC)),
        Case("totalbinarysize-alone", frame("Message", lone_total) + NEXT_FRAME,
             "without a binarysizes slot there is no chunk; a lone totalbinarysize is not "
             "looked at", req4, ok(desc("Message", lone_total), NEXT_DESC)),
    ]


# (name, binarysizes text, totalbinarysize text or None, why it is invalid)
INVALID_SIZES = [
    ("negative", "-3", None, "a negative size"),
    ("plus-sign", "+3", None, "a sign (non-negative integers have none)"),
    ("letters", "3a", None, "letters after the digits"),
    ("word", "three", None, "a word"),
    ("semicolons", "3;5", None, "';' as separator"),
    ("spaces", "3 5", None, "a space as separator"),
    ("trailing-comma", "3,", None, "a trailing comma (an empty item)"),
    ("double-comma", "3,,5", None, "an empty item between commas"),
    ("decimal", "3.0", None, "a decimal point"),
    ("hex", "0x3", None, "hexadecimal"),
    ("fullwidth-digits", "\uff13", None, "a non-ASCII digit (U+FF13)"),
    ("total-mismatch", "3,5", "9", "totalbinarysize 9 is not 3+5"),
    ("total-not-a-number", "3", "three", "a totalbinarysize that is not an integer"),
    ("total-empty", "3", "", "an empty totalbinarysize"),
    ("total-without-sizes", "", "3", "an empty list whose total is 3"),
]


def invalid_size_cases() -> list[Case]:
    cases = []
    for name, sizes, total, why in INVALID_SIZES:
        xml = sizes_xml(sizes, total)
        cases.append(Case(
            f"binarysizes-invalid-{name}", frame("Message", xml, b"\xee" * 8),
            f"BINARY_SIZES_INVALID: {why}; refused once the XML is read, before any chunk",
            ["OA-FRAME-4"], error("BINARY_SIZES_INVALID", 12 + len(xml)),
        ))
    dup = msg("Vec.Dup", "<binarysizes>2</binarysizes><binarysizes>2</binarysizes>")
    twice = "<totalbinarysize>2</totalbinarysize>" * 2
    dup_total = msg("Vec.Dup", f"<binarysizes>2</binarysizes>{twice}")
    child = msg("Vec.Child", "<binarysizes><n>2</n></binarysizes>")
    after = sizes_xml("3;5")
    return [
        *cases,
        Case("binarysizes-invalid-repeated", frame("Message", dup, b"ab", b"cd"),
             "two binarysizes slots: the frame's end is ambiguous", ["OA-FRAME-4"],
             error("BINARY_SIZES_INVALID", 12 + len(dup))),
        Case("binarysizes-invalid-repeated-total", frame("Message", dup_total, b"ab"),
             "two totalbinarysize slots", ["OA-FRAME-4"],
             error("BINARY_SIZES_INVALID", 12 + len(dup_total))),
        Case("binarysizes-invalid-element", frame("Message", child, b"ab"),
             "a binarysizes slot holding an element instead of a list", ["OA-FRAME-4"],
             error("BINARY_SIZES_INVALID", 12 + len(child))),
        Case("binarysizes-invalid-after-frame", NEXT_FRAME + frame("Message", after, b"x" * 8),
             "a good frame, then one with binarysizes 3;5: the good frame is delivered first",
             ["OA-FRAME-4", "OA-FRAME-11"],
             error("BINARY_SIZES_INVALID", len(NEXT_FRAME) + 12 + len(after), NEXT_DESC)),
    ]


def unparsable_cases() -> list[Case]:
    bad = b"<message><type>Vec.Bad</type><binarysizes>8</binarysizes><to>WB1</to"
    doctype = b"<!DOCTYPE message>" + sizes_xml("8", "8", "Vec.Doctype")
    not_message = b"<msg><type>Vec.Root</type><binarysizes>8</binarysizes></msg>"
    deep = sizes_xml("8", "8", "Vec.Deep").replace(
        b'<content language="">', b'<content language="xml">' + b"<d>" * 63 + b"</d>" * 63
    )
    chunk = bytes(range(1, 9))  # not a tag: read as the next header, refused at its 8th byte
    req = ["OA-FRAME-13", "OA-FRAME-4"]
    skip = "announces no chunk (OA-FRAME-13): the next frame follows the XML at once"
    return [
        Case("unparsable-binarysizes-then-chunk", frame("Message", bad, chunk),
             "malformed XML whose text holds <binarysizes>8</binarysizes>, followed by the 8 "
             "bytes the sender meant as a chunk: no chunk is assumed, so those bytes are read "
             "as the next header and refused", [*req, "OA-FRAME-6"],
             error("FRAME_UNKNOWN_TAG", 12 + len(bad) + 8, desc("Message", bad))),
        Case("unparsable-binarysizes-then-frame", frame("Message", bad) + NEXT_FRAME,
             f"the same malformed XML without chunk bytes {skip}", req,
             ok(desc("Message", bad), NEXT_DESC)),
        Case("forbidden-doctype-binarysizes", frame("Message", doctype) + NEXT_FRAME,
             f"XML with a DOCTYPE (XML_FORBIDDEN) and a binarysizes slot {skip}",
             [*req, "OA-SEC-1"], ok(desc("Message", doctype), NEXT_DESC)),
        Case("root-not-message-binarysizes", frame("Message", not_message) + NEXT_FRAME,
             f"a root other than message (XML_MALFORMED) with a binarysizes child {skip}",
             [*req, "OA-MSG-1"], ok(desc("Message", not_message), NEXT_DESC)),
        Case("too-deep-binarysizes", frame("Message", deep) + NEXT_FRAME,
             "XML nested 65 elements deep (XML_TOO_DEEP under the default max-xml-depth 64) "
             f"with a binarysizes slot {skip}", [*req, "OA-LIM-3"],
             ok(desc("Message", deep), NEXT_DESC)),
    ]


def utf8_cases() -> list[Case]:
    text = "Grüße ☃ 𝄞 日本語 ÆØÅ"
    xml = msg("Vec.Utf8", "", text)
    chars = len(xml.decode("utf-8"))
    rest = xml[chars:]
    assert len(rest) >= 8 and rest[:1] not in b"MRB"  # the leftover cannot start a tag
    wrong = header("Message", chars) + xml
    return [
        Case("utf8-multibyte", frame("Message", xml),
             f"UTF-8 content {text!r}: L counts {len(xml)} bytes, not {chars} characters",
             F, ok(desc("Message", xml))),
        Case("utf8-length-in-characters", wrong,
             f"the same XML with L = {chars} (its length in characters): the reader takes "
             f"{chars} bytes as the XML, and the {len(rest)} bytes left over are read as the "
             "next header and refused", ["OA-FRAME-3", "OA-FRAME-6"],
             error("FRAME_UNKNOWN_TAG", 12 + chars + 8, desc("Message", xml[:chars]))),
    ]


def limit_cases() -> list[Case]:
    small = {"max_xml": 64, "max_binary": 16}
    at = b"<message><type>Vec.L</type><c>" + b"x" * 20 + b"</c></message>"
    over = at.replace(b"<c>", b"<c>x")
    assert len(at) == 64 and len(over) == 65
    bin_at, bin_over = sizes_xml("10,6"), sizes_xml("10,7")
    huge = sizes_xml("9" * 30)
    mib16, mib64 = DEFAULT_LIMITS["max_xml"], DEFAULT_LIMITS["max_binary"]
    half = mib64 // 2
    at_total, over_total = sizes_xml(f"{half},{half}"), sizes_xml(str(mib64 + 1))
    xml_req, bin_req = ["OA-FRAME-7", "OA-LIM-1"], ["OA-FRAME-7", "OA-LIM-2"]
    return [
        Case("limit-xml-at-max", frame("Message", at),
             "L == max_xml (64) is accepted", xml_req, ok(desc("Message", at)), limits=small),
        Case("limit-xml-over-max", frame("Message", over),
             "L == max_xml + 1 is FRAME_TOO_LARGE, refused from the header before the body",
             xml_req, error("FRAME_TOO_LARGE", 12), limits=small),
        Case("limit-xml-zero", frame("Message", b""),
             "L == 0 with max_xml 0: an empty body is well framed (the XML error is the "
             "codec's)", xml_req, ok(desc("Message", b"")), limits={"max_xml": 0, "max_binary": 0}),
        Case("limit-binary-at-max", frame("Message", bin_at, b"a" * 10, b"b" * 6),
             "chunks totalling max_binary (16) are accepted", bin_req,
             ok(desc("Message", bin_at, b"a" * 10, b"b" * 6)), limits={**small, "max_xml": 1024}),
        Case("limit-binary-over-max", frame("Message", bin_over, b"a" * 10, b"b" * 7),
             "chunks totalling max_binary + 1 are BINARY_TOO_LARGE, refused once the XML is "
             "read, before any chunk", bin_req, error("BINARY_TOO_LARGE", 12 + len(bin_over)),
             limits={**small, "max_xml": 1024}),
        Case("limit-binarym-at-max", frame("BinaryM", b"c" * 16),
             "a BinaryM chunk of max_binary (16) bytes is accepted", ["OA-FRAME-5", *bin_req],
             ok(desc("BinaryM", b"c" * 16)), limits=small),
        Case("limit-binarym-over-max", frame("BinaryM", b"c" * 17),
             "a BinaryM length of max_binary + 1 is BINARY_TOO_LARGE from the header",
             ["OA-FRAME-5", *bin_req], error("BINARY_TOO_LARGE", 12), limits=small),
        Case("default-xml-at-limit", header("Message", mib16),
             "only a header announcing 16 MiB, the default XML limit: accepted, so the stream "
             "ends inside the frame", [*xml_req, "OA-FRAME-8"], truncated()),
        Case("default-xml-over-limit", header("Message", mib16 + 1),
             "only a header announcing 16 MiB + 1: FRAME_TOO_LARGE after 12 bytes", xml_req,
             error("FRAME_TOO_LARGE", 12)),
        Case("default-xml-max-length", header("Receive", 0xFFFFFFFF),
             "a Receive header announcing 4 GiB - 1", xml_req, error("FRAME_TOO_LARGE", 12)),
        Case("default-binarym-at-limit", header("BinaryM", mib64),
             "only a BinaryM header announcing 64 MiB, the default binary limit: accepted",
             [*bin_req, "OA-FRAME-8"], truncated()),
        Case("default-binarym-over-limit", header("BinaryM", mib64 + 1),
             "only a BinaryM header announcing 64 MiB + 1", bin_req,
             error("BINARY_TOO_LARGE", 12)),
        Case("default-binarysizes-at-limit", frame("Message", at_total),
             "binarysizes totalling 64 MiB, without the chunks: accepted, then truncated",
             [*bin_req, "OA-FRAME-8"], truncated()),
        Case("default-binarysizes-over-limit", frame("Message", over_total) + b"z" * 64,
             "binarysizes announcing 64 MiB + 1: BINARY_TOO_LARGE once the XML is read",
             bin_req, error("BINARY_TOO_LARGE", 12 + len(over_total))),
        Case("default-binarysizes-huge-number", frame("Message", huge),
             "a 30-digit chunk size: a valid list whose total exceeds the limit", bin_req,
             error("BINARY_TOO_LARGE", 12 + len(huge))),
    ]


def tag_cases() -> list[Case]:
    body = msg("Vec.Tag")
    req = ["OA-FRAME-2", "OA-FRAME-6"]
    bad_fields = [
        ("uppercase", b"MESSAGE\0", "MESSAGE (tags are case-sensitive)"),
        ("messag-x01", b"Messag\x01\0", "Messag followed by 0x01"),
        ("non-nul-8th-byte", b"Message\x01", "Message followed by 0x01 instead of NUL"),
        ("space-for-nul", b"Receive ", "Receive followed by a space instead of NUL"),
        ("binarym-lowercase-m", b"Binarym\0", "Binarym"),
        ("short-tag-padded", b"Msg\0\0\0\0\0", "a shorter tag NUL-padded (none is defined)"),
        ("all-nul", b"\0" * 8, "eight NUL bytes"),
        ("http-get", b"GET / HT", "an HTTP request line"),
    ]
    cases = [
        Case(f"tag-{name}", fld + struct.pack("<I", len(body)) + body, f"unknown tag: {why}",
             req, error("FRAME_UNKNOWN_TAG", 8))
        for name, fld, why in bad_fields
    ]
    return [
        *cases,
        Case("tag-after-good-frame", NEXT_FRAME + b"Messages" + struct.pack("<I", 4) + b"abcd",
             "a good frame, then 'Messages' where the NUL should be", [*req, "OA-FRAME-11"],
             error("FRAME_UNKNOWN_TAG", len(NEXT_FRAME) + 8, NEXT_DESC)),
    ]


def truncation_cases() -> list[Case]:
    body = msg("Vec.Cut")
    sized = sizes_xml("3,5", "8")
    req = ["OA-FRAME-8"]
    return [
        Case("empty-input", b"", "no bytes at all: no frame, and the end is clean", req, ok()),
        Case("message-empty-xml", frame("Message", b""),
             "a Message frame with L = 0 is well framed", ["OA-FRAME-1"], ok(desc("Message", b""))),
        Case("truncated-in-tag", b"Mess", "the stream ends inside the tag", req, truncated()),
        Case("truncated-in-length", header("Message", len(body))[:10],
             "the stream ends inside the length field", req, truncated()),
        Case("truncated-header-11", header("Message", len(body))[:11],
             "the stream ends one byte short of a full header", req, truncated()),
        Case("truncated-header-only", header("Message", len(body)),
             "a complete header and no body", req, truncated()),
        Case("truncated-body", frame("Message", body)[:-1],
             "the stream ends one byte short of the XML", req, truncated()),
        Case("truncated-chunk", frame("Message", sized, b"abc", b"defgh")[:-2],
             "binarysizes 3,5 but only 6 chunk bytes arrive", [*req, "OA-FRAME-4"], truncated()),
        Case("truncated-before-chunks", frame("Message", sized),
             "binarysizes 3,5 and the stream ends right after the XML",
             [*req, "OA-FRAME-4"], truncated()),
        Case("truncated-binarym", frame("BinaryM", b"0123456789")[:-6],
             "a BinaryM frame of 10 bytes of which 4 arrive", [*req, "OA-FRAME-5"], truncated()),
        Case("frame-then-truncated", NEXT_FRAME + header("Receive", 20)[:5],
             "a complete frame, then the first 5 bytes of the next: the complete frame is "
             "delivered, the partial one never is", [*req, "OA-FRAME-11"], truncated(NEXT_DESC)),
    ]


def stream_cases() -> list[Case]:
    s1 = datasample(b"\x10\x20", id="7", type="Binary")
    xml = sizes_xml(str(len(s1)), str(len(s1)), "Vec.Mixed")
    parts = [
        (frame("Message", NEXT), desc("Message", NEXT)),
        (frame("BinaryM", s1), desc("BinaryM", s1)),
        (frame("Receive", msg("RECEIVE_NAME_NOTIFICATION")),
         desc("Receive", msg("RECEIVE_NAME_NOTIFICATION"))),
        (frame("Message", xml, s1), desc("Message", xml, s1)),
        (frame("Message", b""), desc("Message", b"")),
    ]
    many = [msg(f"Vec.Many.{i}", "", "x" * i) for i in range(40)]
    return [
        Case("stream-mixed-tags", b"".join(p[0] for p in parts),
             "Message, BinaryM, Receive, Message with a chunk and an empty Message in one buffer",
             ["OA-FRAME-11", "OA-FRAME-4", "OA-FRAME-5"], ok(*(p[1] for p in parts))),
        Case("stream-forty-frames", b"".join(frame("Message", m) for m in many),
             "forty frames of growing size in one buffer", ["OA-FRAME-11"],
             ok(*(desc("Message", m) for m in many))),
    ]


def all_cases() -> list[Case]:
    cases = [
        *captured_cases(), *binary_cases(), *invalid_size_cases(), *unparsable_cases(),
        *utf8_cases(), *limit_cases(), *tag_cases(), *truncation_cases(), *stream_cases(),
    ]
    names = [c.name for c in cases]
    assert len(set(names)) == len(names), "case names must be unique"
    return cases


# fmt: on


# -- output -------------------------------------------------------------------------------------


def manifest(cases: list[Case]) -> str:
    """Return manifest.json: the header keys, then one case per line (easy to diff and grep)."""
    head = {
        "format": FORMAT,
        "description": "OpenAIR 1.0 frame vectors (spec section 2, OA-FRAME-*, OA-LIM-1/2). "
        "Generated by tools/gen_frame_vectors.py; see README.md in this folder.",
        "default_limits": DEFAULT_LIMITS,
    }
    lines = [f" {json.dumps(k)}: {json.dumps(v, ensure_ascii=True)}," for k, v in head.items()]
    rows = ",\n".join(f"  {json.dumps(c.entry(), ensure_ascii=True)}" for c in cases)
    return "{\n" + "\n".join(lines) + '\n "cases": [\n' + rows + "\n ]\n}\n"


def wanted_files(cases: list[Case]) -> dict[str, bytes]:
    files = {f"{c.name}.bin": c.data for c in cases}
    files["manifest.json"] = manifest(cases).encode("ascii")
    return files


def check(files: dict[str, bytes]) -> list[str]:
    """Return the problems that make the folder differ from `files`."""
    problems = [
        f"{name}: {'missing' if not (OUT / name).exists() else 'stale'}"
        for name, data in files.items()
        if not (OUT / name).exists() or (OUT / name).read_bytes() != data
    ]
    extra = sorted(p.name for p in OUT.glob("*.bin") if p.name not in files)
    return problems + [f"{name}: not produced by this script" for name in extra]


def main(argv: list[str] | None = None) -> int:
    """Write the vectors, or with --check report whether the files are up to date."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--check", action="store_true", help="fail if a file is stale")
    args = parser.parse_args(argv)
    files = wanted_files(all_cases())
    if args.check:
        problems = check(files)
        for line in problems:
            print(f"gen_frame_vectors: {line}", file=sys.stderr)
        return 1 if problems else 0
    OUT.mkdir(parents=True, exist_ok=True)
    for stale in OUT.glob("*.bin"):
        if stale.name not in files:
            stale.unlink()
    for name, data in files.items():
        path = OUT / name
        if not path.exists() or path.read_bytes() != data:
            path.write_bytes(data)
    print(f"gen_frame_vectors: {len(files) - 1} cases in {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
