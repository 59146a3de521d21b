"""Framing cases (spec section 2): good and bad frames, split and joined writes, binary chunks,
sizes at and beyond the advertised limits, and the sticky close after a framing error.

Bad frames are written byte by byte with `RawConnection.send`; each case then proves either
that the connection stays usable (a PING round trip) or that the server closed it without a
reply, reading every frame until the close.
"""

from __future__ import annotations

import struct

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import (
    check_error,
    error_name,
    esc,
    frames_until_closed,
    message_xml,
    parse_xml,
    ping_ok,
    retrieved,
    send_big,
    send_xml,
)
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.model import NotApplicable
from openair_conformance.registry import case

_MiB = 1 << 20


def _header(tag: bytes, length: int) -> bytes:
    return tag + struct.pack("<I", length)


def _frame(xml: bytes, tag: bytes = b"Message\x00") -> bytes:
    return _header(tag, len(xml)) + xml


def _ping(ctx: CaseContext) -> bytes:
    return message_xml("PING", to="CNS", sender=ctx.name("F"))


async def _closed_without_reply(ctx: CaseContext, raw: RawConnection, what: str, req: str) -> None:
    frames = await frames_until_closed(ctx, raw, what=f"close after {what}")
    ctx.check(
        not frames,
        f"after {what} the server sent {len(frames)} frame(s) before closing",
        expected=f"the connection closed at once, without a reply ({req})",
    )


async def _error_then_close(
    ctx: CaseContext, raw: RawConnection, name: str, what: str, req: str
) -> None:
    frames = await frames_until_closed(ctx, raw, what=f"close after {what}")
    ctx.check(bool(frames), f"{what}: the server closed without RECEIVE_ERROR", expected=req)
    first = raw.stream.decode(frames[0])
    check_error(ctx, first, names=(name,), what=what, req=req)
    ctx.check(len(frames) == 1, f"{what}: {len(frames)} frames before the close", expected=req)


# -- 2.1 good frames --------------------------------------------------------------------------


@case(
    id="FRAME-001",
    title="A reply frame is tag, NUL, little-endian byte length, then exactly that much UTF-8 XML",
    section="2.1",
    requirements=("OA-FRAME-1", "OA-FRAME-3", "OA-MSG-1", "OA-SESS-20"),
    allowed=("header 'Message' 00 L (LE) and L bytes of XML whose root is <message>",),
)
async def reply_frame_bytes(ctx: CaseContext) -> None:
    """Send an unknown command whose name has non-ASCII letters; read the reply's raw bytes.

    Catches: a length written big-endian, a length that counts characters (the reply names the
    command, so its XML holds multi-byte characters), a missing NUL after the tag.
    """
    raw = await ctx.raw()
    command = f"CONF_\u00dcNKNOWN_\u00e9_{ctx.run_id}"
    await raw.send(_frame(message_xml(command, to="CNS", sender=ctx.name("F"))))
    data = b""
    while len(data) < 12 or len(data) < 12 + struct.unpack("<I", data[8:12])[0]:
        chunk = await ctx.wait(raw.stream.read_bytes(), what="reply bytes")
        ctx.check(bool(chunk), "the server closed the connection", expected="a reply (OA-SESS-20)")
        data += chunk
    ctx.check(data[:8] == b"Message\x00", f"the header starts {data[:8]!r}", expected="OA-FRAME-1")
    length = struct.unpack("<I", data[8:12])[0]
    body = data[12 : 12 + length]
    ctx.check(
        len(data) == 12 + length,
        f"{len(data) - 12 - length} bytes follow the XML",
        expected="OA-FRAME-1",
    )
    try:
        root = parse_xml(body)
    except ValueError as exc:
        ctx.fail(
            f"the {length} bytes are not XML: {exc}",
            expected="L = the XML's byte length (OA-FRAME-3)",
        )
    ctx.check(str(root.tag).lower() == "message", f"root {root.tag!r}", expected="<message>")
    ctx.check(
        command in body.decode("utf-8"),
        "the reply does not name the command",
        expected="OA-SESS-20",
    )


@case(
    id="FRAME-002",
    title="A post whose XML holds multi-byte characters is read by byte length and kept intact",
    section="2.1",
    requirements=("OA-FRAME-3", "OA-WB-4"),
    allowed=("the stored copy's content equals the posted content",),
)
async def multibyte_content(ctx: CaseContext) -> None:
    """Post content with two-, three- and four-byte UTF-8 characters, retrieve it by id.

    Catches: a receiver that counts characters (it would cut the frame and lose sync) or
    re-encodes the text (mojibake in the stored copy).
    """
    client = await ctx.module("C", bind=False)
    text = "Gr\u00fc\u00dfe \u2713 \U0001d11e \u65e5\u672c"
    await client.post("WB1", ctx.type("Utf8"), text)
    assert client.last_sent is not None
    spec = f'<retrieve from="WB1" id="{client.last_sent.id}"/>'
    found = await retrieved(ctx, client, spec)
    ctx.check(
        [m.content for m in found] == [text],
        f"the stored content is {[m.content for m in found]!r}",
        expected=f"[{text!r}] (OA-FRAME-3)",
    )


@case(
    id="FRAME-003",
    title="A frame split across many reads is accepted",
    section="2.1",
    requirements=("OA-FRAME-11",),
    allowed=("PING_SUCCESS once the last byte has arrived",),
)
async def split_frame(ctx: CaseContext) -> None:
    """Send a PING frame in four pieces (inside the tag, the length and the XML), with a round
    trip on another connection between pieces so that each arrives in its own read.

    Catches: a reader that expects a whole header or a whole frame per read.
    """
    raw = await ctx.raw()
    other = await ctx.raw("other")
    data = _frame(_ping(ctx))
    for piece in (data[:3], data[3:10], data[10:40], data[40:]):
        await raw.send(piece)
        await ping_ok(ctx, other, what="on another connection", req="OA-FRAME-11")
    reply = await raw.read_message()
    ctx.check(
        reply.type == "PING_SUCCESS", f"the split PING got {reply.type}", expected="OA-FRAME-11"
    )


@case(
    id="FRAME-004",
    title="A frame and the start of the next one in one write are both handled",
    section="2.1",
    requirements=("OA-FRAME-11",),
    allowed=("PING_SUCCESS for the first PING, then for the second once it is complete",),
)
async def frame_and_a_half(ctx: CaseContext) -> None:
    """Write one PING frame plus the first 9 bytes of a second; read the reply; send the rest.

    Catches: a reader that drops the bytes after the first frame of a read.
    """
    raw = await ctx.raw()
    first, second = _frame(_ping(ctx)), _frame(_ping(ctx))
    await raw.send(first + second[:9])
    one = await raw.read_message()
    await raw.send(second[9:])
    two = await raw.read_message()
    ctx.check(
        (one.type, two.type) == ("PING_SUCCESS", "PING_SUCCESS"),
        f"the two PINGs got {one.type} and {two.type}",
        expected="PING_SUCCESS twice (OA-FRAME-11)",
    )


@case(
    id="FRAME-005",
    title="Thirty frames in one write, cut inside a header, are all answered in order",
    section="2.1",
    requirements=("OA-FRAME-11", "OA-SESS-17", "OA-SESS-2"),
    needs=("pipelining",),
    allowed=("thirty PING_SUCCESS replies, in request order",),
)
async def many_frames(ctx: CaseContext) -> None:
    """Write 30 PING frames in two writes, the cut falling inside the 16th header.

    Catches: frames lost when a read holds several, and a header split across reads.
    """
    raw = await ctx.raw()
    xmls = [_ping(ctx) for _ in range(30)]
    data = b"".join(_frame(x) for x in xmls)
    cut = sum(len(_frame(x)) for x in xmls[:15]) + 5
    await raw.send(data[:cut])
    await raw.send(data[cut:])
    ids = [parse_xml(x).findtext("id") for x in xmls]
    for index, want in enumerate(ids):
        reply = await raw.read_message()
        ctx.check(
            reply.type == "PING_SUCCESS" and reply.isresponse == want,
            f"reply #{index + 1} is {reply.type} for {reply.isresponse!r}",
            expected="PING_SUCCESS for each PING, in order (OA-SESS-2)",
        )


# -- 2.2 framing errors -----------------------------------------------------------------------


@case(
    id="FRAME-006",
    title="An unknown tag closes the connection without a reply; later bytes are ignored",
    section="2.2",
    requirements=("OA-FRAME-6", "OA-FRAME-9", "OA-ERR-4"),
    allowed=("the server closes the connection and sends nothing, not even for the PING after it",),
)
async def unknown_tag(ctx: CaseContext) -> None:
    """Write a frame tagged `Garbage` and a valid PING frame in one write.

    Catches: a server that answers or skips an unknown frame (Psyclone closes only after about
    13 s, DEV-20), and one that resynchronises and answers the PING behind it.
    """
    raw = await ctx.raw()
    await raw.send(_frame(_ping(ctx), b"Garbage\x00") + _frame(_ping(ctx)))
    await _closed_without_reply(ctx, raw, "a Garbage frame", "OA-FRAME-6, OA-FRAME-9")
    await ping_ok(ctx, await ctx.raw("other"), what="on another connection", req="OA-ERR-4")


@case(
    id="FRAME-007",
    title="Tags are case-sensitive: 'message' and 'MESSAGE' close the connection",
    section="2.2",
    requirements=("OA-FRAME-2", "OA-FRAME-6"),
    allowed=("each connection is closed without a reply",),
)
async def tag_case(ctx: CaseContext) -> None:
    """Send a PING framed with the tag `message`, and on another connection `MESSAGE`.

    Catches: a tag compared case-insensitively.
    """
    for tag in (b"message\x00", b"MESSAGE\x00", b"receive\x00"):
        raw = await ctx.raw(tag[:7].decode())
        await raw.send(_frame(_ping(ctx), tag))
        await _closed_without_reply(ctx, raw, f"a frame tagged {tag[:7]!r}", "OA-FRAME-2")


@case(
    id="FRAME-008",
    title="A byte other than NUL after the tag closes the connection without a reply",
    section="2.2",
    requirements=("OA-FRAME-6", "OA-FRAME-1"),
    allowed=("the connection is closed without a reply",),
)
async def tag_not_nul(ctx: CaseContext) -> None:
    """Send `Message` followed by a space instead of NUL, then a well-formed PING.

    Catches: a reader that checks only the first seven bytes.
    """
    raw = await ctx.raw()
    await raw.send(_frame(_ping(ctx), b"Message ") + _frame(_ping(ctx)))
    await _closed_without_reply(ctx, raw, "'Message' followed by a space", "OA-FRAME-6")


@case(
    id="FRAME-009",
    title="A length above max-frame-xml is answered FRAME_TOO_LARGE and the connection closed",
    section="2.2",
    requirements=("OA-FRAME-7", "OA-LIM-1", "OA-ERR-4"),
    allowed=(
        "one RECEIVE_ERROR 'FRAME_TOO_LARGE: …', then the close; other connections unaffected",
    ),
)
async def frame_too_large(ctx: CaseContext) -> None:
    """Announce max-frame-xml + 1 bytes and send only a few; the server must not wait for them.

    Catches: a server that allocates or waits for the announced length (Psyclone neither
    answers nor closes, DEV-21), and one that closes without the error reply.
    """
    limit = ctx.server.limit("max-frame-xml", 16 * _MiB)
    raw = await ctx.raw()
    await raw.send(_header(b"Message\x00", min(limit + 1, 0xFFFFFFFF)) + _ping(ctx)[:64])
    await _error_then_close(ctx, raw, "FRAME_TOO_LARGE", "an oversized frame", "OA-FRAME-7")
    await ping_ok(ctx, await ctx.raw("other"), what="on another connection", req="OA-ERR-4")


@case(
    id="FRAME-010",
    title="A frame of exactly max-frame-xml bytes is accepted",
    section="2.1",
    requirements=("OA-LIM-1", "OA-FRAME-3"),
    allowed=("PING_SUCCESS",),
)
async def frame_at_limit(ctx: CaseContext) -> None:
    """Send a PING whose XML (padded with content) is exactly max-frame-xml bytes long.

    Catches: an off-by-one limit (`>=` instead of `>`).
    """
    limit = ctx.server.limit("max-frame-xml", 16 * _MiB)
    if limit > 32 * _MiB:
        raise NotApplicable(f"max-frame-xml is {limit} bytes; the suite sends at most 32 MiB")
    base = message_xml("PING", to="CNS", sender=ctx.name("F"), content="")
    pad = limit - len(base)
    xml = base.replace(b'language=""></content>', b'language="">' + b"x" * pad + b"</content>")
    raw = await ctx.raw()
    await send_big(ctx, raw, _frame(xml), what="a frame at the limit")
    reply = await raw.read_message(timeout=ctx.deadline * 4)
    ctx.check(
        reply.type == "PING_SUCCESS",
        f"a {len(xml)}-byte PING got {reply.type} {reply.content[:80]!r}",
        expected="OA-LIM-1",
    )


@case(
    id="FRAME-011",
    title="binarysizes above max-frame-binary gets BINARY_TOO_LARGE and the connection closes",
    section="2.2",
    requirements=("OA-FRAME-7", "OA-LIM-2"),
    allowed=("one RECEIVE_ERROR 'BINARY_TOO_LARGE: …', then the close",),
)
async def binary_too_large(ctx: CaseContext) -> None:
    """Send a post announcing one chunk of max-frame-binary + 1 bytes and no chunk.

    Catches: a server that waits for (or allocates) the announced chunks.
    """
    limit = ctx.server.limit("max-frame-binary", 64 * _MiB)
    size = limit + 1
    body = f"<binarysizes>{size}</binarysizes><totalbinarysize>{size}</totalbinarysize>"
    raw = await ctx.raw()
    await raw.send(_frame(message_xml(ctx.type("Big"), to="WB1", sender=ctx.name("F"), body=body)))
    await _error_then_close(ctx, raw, "BINARY_TOO_LARGE", "oversized binary chunks", "OA-FRAME-7")


@case(
    id="FRAME-012",
    title="An invalid binarysizes list is answered BINARY_SIZES_INVALID and the connection closed",
    section="2.1",
    requirements=("OA-FRAME-4",),
    allowed=("one RECEIVE_ERROR 'BINARY_SIZES_INVALID: …', then the close",),
)
async def binary_sizes_invalid(ctx: CaseContext) -> None:
    """Send `binarysizes` `3,x`; on another connection `3,4` with `totalbinarysize` 8.

    Catches: a reader that guesses chunk sizes from a bad list and loses sync silently.
    """
    bodies = (
        "<binarysizes>3,x</binarysizes>",
        "<binarysizes>3,4</binarysizes><totalbinarysize>8</totalbinarysize>",
    )
    for body in bodies:
        raw = await ctx.raw()
        xml = message_xml(ctx.type("Bin"), to="WB1", sender=ctx.name("F"), body=body)
        await raw.send(_frame(xml) + b"abcdefg")
        await _error_then_close(ctx, raw, "BINARY_SIZES_INVALID", body, "OA-FRAME-4")


@case(
    id="FRAME-013",
    title="A post with binary chunks is read whole: the next frame is in sync",
    section="2.1",
    requirements=("OA-FRAME-4", "OA-FRAME-1"),
    allowed=("RECEIVE_ACCEPT for the post, then PING_SUCCESS",),
)
async def binary_chunks(ctx: CaseContext) -> None:
    """Post with chunks of 3, 0 and 5 bytes (binarysizes `3, 0 ,5`), then PING.

    Catches: chunks not read (their bytes taken for the next header), an empty chunk
    mishandled, white space in the list refused.
    """
    raw = await ctx.raw()
    body = "<binarysizes> 3, 0 ,5 </binarysizes><totalbinarysize>8</totalbinarysize>"
    xml = message_xml(ctx.type("Bin"), to="WB1", sender=ctx.name("F"), body=body)
    await raw.send(_frame(xml) + b"abc" + b"12345")
    reply = await raw.read_message()
    ctx.check(
        reply.type == "RECEIVE_ACCEPT",
        f"the post got {reply.type} {reply.content!r}",
        expected="OA-FRAME-4",
    )
    await ping_ok(ctx, raw, what="after the chunks", req="OA-FRAME-4")


@case(
    id="FRAME-014",
    title="A BinaryM frame sent to the main port is answered UNKNOWN_COMMAND BinaryOnly",
    section="2.1",
    requirements=("OA-FRAME-5", "OA-STREAM-11", "OA-GEN-4"),
    allowed=(
        "UNKNOWN_COMMAND with content 'Offending cmd: BinaryOnly'; the connection stays usable",
    ),
)
async def binarym_elsewhere(ctx: CaseContext) -> None:
    """Send one BinaryM frame (a 3-byte datasample chunk, no XML), then PING.

    Catches: a BinaryM length read as XML, or the chunk left in the stream.
    """
    raw = await ctx.raw()
    chunk = struct.pack("<I", 3) + b"abc" + b"\x00"
    await raw.send(_header(b"BinaryM\x00", len(chunk)) + chunk)
    reply = await raw.read_message()
    ctx.check(
        reply.type == "UNKNOWN_COMMAND" and reply.content.strip() == "Offending cmd: BinaryOnly",
        f"the BinaryM frame got {reply.type} {reply.content!r}",
        expected="UNKNOWN_COMMAND 'Offending cmd: BinaryOnly' (OA-STREAM-11)",
    )
    await ping_ok(ctx, raw, what="after the BinaryM frame", req="OA-FRAME-5")


@case(
    id="FRAME-015",
    title="A frame cut off by the end of the connection is never acted upon",
    section="2.2",
    requirements=("OA-FRAME-8",),
    allowed=("the partial post is not stored",),
)
async def truncated_frame(ctx: CaseContext) -> None:
    """Send a complete post XML announcing a 10-byte chunk, only 5 chunk bytes, a round trip
    on another connection, then close; retrieve the post's id.

    Catches: a server that acts on the XML before the frame's chunks have all arrived.
    """
    raw = await ctx.raw()
    body = "<binarysizes>10</binarysizes><totalbinarysize>10</totalbinarysize>"
    xml = message_xml(
        ctx.type("Cut"), to="WB1", sender=ctx.name("F"), body=body, id=ctx.name("Cut")
    )
    await raw.send(_frame(xml) + b"12345")
    client = await ctx.module("C", bind=False)
    await client.request(Message(type="PING", sender=client.name, to="CNS"))
    await raw.close()
    found = await retrieved(ctx, client, f'<retrieve from="WB1" id="{ctx.name("Cut")}"/>')
    ctx.check(not found, "the truncated post was stored", expected="nothing stored (OA-FRAME-8)")


@case(
    id="FRAME-016",
    title="A Receive frame without RECEIVE_NAME_NOTIFICATION is refused; the connection stays",
    section="2.1",
    requirements=("OA-FRAME-10", "OA-ERR-2"),
    allowed=(
        "RECEIVE_ERROR 'MESSAGE_INVALID: …' for each, then PING in a Message frame is answered",
    ),
)
async def receive_frame_wrong_type(ctx: CaseContext) -> None:
    """Send a PING, then a STATUS, in a Receive frame, then a PING in a Message frame.

    Catches: a server that turns the connection into a callback for any Receive frame, or
    for any type but a few (STATUS sorts after RECEIVE_NAME_NOTIFICATION, PING before it).
    """
    raw = await ctx.raw()
    for type_ in ("PING", "STATUS"):
        xml = message_xml(type_, to="CNS", sender=ctx.name("F"))
        reply = await send_xml(raw, xml, FrameTag.RECEIVE)
        check_error(
            ctx,
            reply,
            names=("MESSAGE_INVALID",),
            what=f"a {type_} in a Receive frame",
            req="OA-FRAME-10",
        )
    await ping_ok(ctx, raw, what="in a Message frame after it", req="OA-FRAME-10")


@case(
    id="FRAME-017",
    title="Unparsable XML announces no chunks: its chunk bytes are read as the next header",
    section="2.2",
    requirements=("OA-FRAME-13", "OA-ERR-3"),
    allowed=("RECEIVE_ERROR 'XML_MALFORMED: …', then the close (the chunk is an unknown tag)",),
)
async def malformed_with_chunks(ctx: CaseContext) -> None:
    """Send malformed XML holding `<binarysizes>12</binarysizes>`, 12 bytes starting `GarbageX`,
    then a PING frame.

    Catches: a server that digs chunk sizes out of XML it could not parse (it would skip the
    12 bytes and answer the PING).
    """
    raw = await ctx.raw()
    bad = f"<message><type>{esc(ctx.type('Bad'))}</type><binarysizes>12</binarysizes><to>WB1</to"
    await raw.send(_frame(bad.encode()) + b"GarbageX\x00\x00\x00\x00" + _frame(_ping(ctx)))
    frames = await frames_until_closed(ctx, raw, what="the close after the chunk bytes")
    names = [error_name(raw.stream.decode(f).content) for f in frames]
    ctx.check(
        names == ["XML_MALFORMED"],
        f"the server sent {len(frames)} frame(s): {names}",
        expected="one RECEIVE_ERROR XML_MALFORMED, then the close (OA-FRAME-13)",
    )


@case(
    id="FRAME-018",
    title="A frame that stalls longer than the frame deadline closes the connection",
    section="2.2",
    requirements=("OA-FRAME-12",),
    allowed=("the close, without a reply, after frame-deadline-ms",),
)
async def frame_deadline(ctx: CaseContext) -> None:
    """Send a header and 10 bytes of XML, then nothing; wait for the close (only when the
    advertised frame-deadline-ms is at most 10 deadlines, so the case stays cheap).

    Catches: a reader that waits for the rest of a frame forever (Psyclone, DEV-22).
    """
    limit_ms = ctx.server.limit("frame-deadline-ms", 30_000)
    if limit_ms / 1000 > 10 * ctx.deadline:
        raise NotApplicable(f"frame-deadline-ms is {limit_ms}; too long to wait for")
    raw = await ctx.raw()
    xml = _ping(ctx)
    await raw.send(_header(b"Message\x00", len(xml)) + xml[:10])
    frames = await frames_until_closed(
        ctx, raw, what="the close after the frame deadline", timeout=limit_ms / 1000 + ctx.deadline
    )
    ctx.check(not frames, f"{len(frames)} frame(s) before the close", expected="OA-FRAME-12")
