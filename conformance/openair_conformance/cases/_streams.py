"""Helpers of the stream cases (spec section 11): datasample chunks, a stream client, push readers.

Chunks are written and read here, independently of the reference's `openair.protocol.datasample`, so
that a shared bug cannot make the server and the suite agree. `StreamClient` sends media commands on
one raw connection, one request at a time, and checks the reply types the streams contract
gives. `PushReader` plays a push subscriber (11.6) on a raw connection: it reads the pushed
`DATASAMPLE` messages in the background and acknowledges them, or holds the acknowledgements
while paused (a slow subscriber).

Isolation on a shared stream: samples are found by a parameter unique to the case (`marker`),
and samples that carry explicit timestamps use a window of one minute in the year 2000–2008
that depends on the run and the case (`past_window`), so that time lookups never meet another
case's samples.
"""

from __future__ import annotations

import contextlib
import time
import zlib
from collections.abc import Sequence
from dataclasses import dataclass

from lxml import etree

from openair.protocol.framing import Frame, FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import check_error, error_name, esc
from openair_conformance.harness import CaseContext, RawConnection
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
    content_root,
)
from openair_conformance.model import Inconclusive, NotApplicable

__all__ = [
    "MIB",
    "Sample",
    "StreamClient",
    "check_from",
    "check_sample",
    "chunk",
    "create_stream",
    "create_stream_request",
    "future_base",
    "marker",
    "past_window",
    "read_chunk",
    "read_time",
    "sample_label",
    "samples_xml",
    "stored_params",
    "stream_under_test",
    "time_xml",
]

MIB = 1 << 20
_SEP = "%sep%"
_EQ = "%equals%"
#: 2000-01-01T00:00:00Z in ms: the start of the windows of explicit past timestamps.
_PAST = 946_684_800_000
_DAY_MS = 86_400_000

Params = tuple[tuple[str, str], ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class Sample:
    """A datasample as the suite reads it: payload bytes and parameters in chunk order."""

    payload: bytes
    params: Params = ()

    def param(self, key: str) -> str | None:
        """Return the value of the first parameter `key`, or None."""
        return next((v for k, v in self.params if k == key), None)

    def int_param(self, key: str) -> int | None:
        """Return parameter `key` as a decimal integer, or None when absent or not one."""
        value = self.param(key)
        return int(value) if value is not None and value.isdigit() else None

    @property
    def id(self) -> int | None:
        """The `builtin:id` parameter as an integer."""
        return self.int_param("builtin:id")

    @property
    def timestamp(self) -> int | None:
        """The `builtin:timestamp` parameter as an integer (ms since the epoch)."""
        return self.int_param("builtin:timestamp")

    def without(self, *keys: str) -> Params:
        """Return the parameters except those named `keys`, in order."""
        return tuple((k, v) for k, v in self.params if k not in keys)


def chunk(payload: bytes, params: Sequence[tuple[str, str]] = ()) -> bytes:
    """Write a datasample chunk: uint32 LE length, payload, `k%equals%v%sep%…`, NUL.

    (OA-STREAM-2)
    """
    text = _SEP.join(f"{k}{_EQ}{v}" for k, v in params).encode("ascii")
    return len(payload).to_bytes(4, "little") + payload + text + b"\0"


def read_chunk(data: bytes) -> Sample:
    """Read a datasample chunk; ValueError saying what is wrong with it (OA-STREAM-2)."""
    if len(data) < 5:
        raise ValueError(f"a chunk of {len(data)} bytes (at least 5 are needed)")
    size = int.from_bytes(data[:4], "little")
    if len(data) < 5 + size:
        raise ValueError(f"payload length {size} but the chunk has {len(data)} bytes")
    if data[-1] != 0:
        raise ValueError("the chunk does not end with NUL")
    text = data[4 + size : -1]
    if b"\0" in text:
        raise ValueError("the parameters hold a NUL")
    try:
        decoded = text.decode("ascii")
    except UnicodeDecodeError as exc:
        raise ValueError(f"the parameters are not ASCII: {text[:60]!r}") from exc
    params: list[tuple[str, str]] = []
    for pair in decoded.split(_SEP) if decoded else ():
        parts = pair.split(_EQ)
        if len(parts) != 2 or not parts[0]:
            raise ValueError(f"parameter {pair[:60]!r} is not key%equals%value")
        params.append((parts[0], parts[1]))
    return Sample(payload=data[4 : 4 + size], params=tuple(params))


def sample_label(msg: Message) -> str:
    """Return the `conf:n` parameter of a DATASAMPLE's sample ("" when it has none)."""
    if msg.type != "DATASAMPLE" or len(msg.binary) != 1:
        return ""
    try:
        return read_chunk(msg.binary[0]).param("conf:n") or ""
    except ValueError:
        return ""


def samples_xml(count: int) -> str:
    """Return `<objectcollection>` of `count` `<object><datasample/></object>`."""
    return "<objectcollection>" + "<object><datasample/></object>" * count + "</objectcollection>"


def time_xml(ms: int, tag: str = "time") -> str:
    """Return a time element for `ms` since the epoch (spec section 4)."""
    return f'<{tag} sec="{ms // 1000}" msec="{ms % 1000}"/>'


def marker(ctx: CaseContext) -> tuple[str, str]:
    """Return the parameter that marks this case's samples on a shared stream."""
    return ("conf:case", f"{ctx.run_id}.{ctx.case.id}")


def past_window(ctx: CaseContext) -> int:
    """Return the start (ms, msec 123) of a one-minute window of timestamps unique to the case.

    The windows lie in the years 2000–2008; no writer that stamps by receive time reaches them.
    """
    slot = zlib.crc32(f"{ctx.run_id}/{ctx.case.id}".encode()) % (1 << 22)
    return _PAST + slot * 60_000 + 123


def future_base() -> int:
    """Return a timestamp (ms) ten days ahead: later than any earlier run's `future_base`."""
    return int(time.time() * 1000) + 10 * _DAY_MS


# -- the stream under test ---------------------------------------------------------------------


async def stream_under_test(ctx: CaseContext) -> str:
    """Return `--stream` (default Stream1) if it resolves; NotApplicable otherwise.

    A server MAY offer no streams (OA-STREAM-15, OA-GEN-4): then the core stream cases have
    nothing to judge.
    """
    raw = await ctx.raw("resolve")
    name = ctx.stream
    request = Message(type="RESOLVE_REQUEST", sender=ctx.name("R"), to="CNS", content=name)
    reply = await raw.request(request)
    await raw.close()
    if reply.type != "RESOLVE_SUCCESS":
        raise NotApplicable(
            f"the stream {name!r} does not resolve ({reply.type}): the server offers no such "
            "stream (OA-STREAM-15); name another with --stream"
        )
    with contextlib.suppress(WakeupUnreadable):  # no location: the main port
        ctx.resolved(name, attributes(content_object(reply, "tcplocation")))
    return name


def create_stream_request(ctx: CaseContext, content: str) -> Message:
    """A Psyclone.System.Create.Stream request from the case's Creator with `content`."""
    return Message(
        type="Psyclone.System.Create.Stream",
        sender=ctx.name("Creator"),
        to="Psyclone",
        content=content,
        content_is_xml=True,
        language="xml",
    )


async def create_stream(
    ctx: CaseContext,
    raw: RawConnection,
    suffix: str,
    *,
    setup: bool = True,
    **attrs: str | int,
) -> str:
    """Create the stream `ctx.name(suffix)` in WB1 with Psyclone.System.Create.Stream.

    `attrs` are further attributes of `<stream>` (type, softcount, idle, …). As a setup step
    (`setup=True`) a refusal is INCONCLUSIVE; otherwise it FAILS (OA-XSTREAM-10), except the
    refusal LIMIT_EXCEEDED naming max-created-streams: a server that has had that many streams
    created (earlier runs) rightly refuses more (OA-LIM-17), so the case cannot run.
    """
    name = ctx.name(suffix)
    extra = "".join(f' {k}="{esc(str(v))}"' for k, v in attrs.items())
    content = f'<stream name="{name}" whiteboard="WB1"{extra}/>'
    reply = await raw.request(create_stream_request(ctx, content))
    if reply.type != "RECEIVE_ACCEPT":
        text = (
            f"Psyclone.System.Create.Stream {content} was answered {reply.type} {reply.content!r}"
        )
        if setup or _created_streams_spent(reply):
            raise Inconclusive(f"setup: {text}")
        ctx.fail(text, expected="RECEIVE_ACCEPT (OA-XSTREAM-10)")
    return name


def _created_streams_spent(reply: Message) -> bool:
    """Whether a refusal of a creation is LIMIT_EXCEEDED naming max-created-streams (OA-LIM-17)."""
    return error_name(reply.content) == "LIMIT_EXCEEDED" and "max-created-streams" in reply.content


# -- a client of one stream --------------------------------------------------------------------


class StreamClient:
    """Media commands to one stream on one raw connection, a request at a time."""

    def __init__(
        self, ctx: CaseContext, raw: RawConnection, stream: str, sender: str, to: str = ""
    ) -> None:
        self.ctx = ctx
        self.raw = raw
        self.stream = stream  # the name replies come from
        self.sender = sender
        self.to = to or stream  # where requests go: the name, or a type (OA-XSTREAM-1)

    @classmethod
    async def open(
        cls, ctx: CaseContext, stream: str, suffix: str = "W", *, to: str = ""
    ) -> StreamClient:
        """Open a raw connection for the writer/reader `ctx.name(suffix)`."""
        raw = await ctx.raw(suffix, component=to or stream)  # its own port, if it has one
        return cls(ctx, raw, stream, ctx.name(suffix), to)

    def message(
        self, type: str, content: str = "", *, xml: bool = False, binary: Sequence[bytes] = ()
    ) -> Message:
        """Build a media command to the stream."""
        return Message(
            type=type,
            sender=self.sender,
            to=self.to,
            content=content,
            content_is_xml=xml,
            language="xml" if xml else "",
            binary=tuple(binary),
        )

    async def request(
        self,
        type: str,
        content: str = "",
        *,
        xml: bool = False,
        binary: Sequence[bytes] = (),
        timeout: float | None = None,
    ) -> Message:
        """Send a media command and return the next message on the connection."""
        msg = self.message(type, content, xml=xml, binary=binary)
        return await self.raw.request(msg, timeout=timeout)

    # -- writing -----------------------------------------------------------------------------

    async def add_chunk(self, data: bytes) -> Message:
        """ADD_SAMPLE with a chunk as given; return the reply."""
        return await self.request("ADD_SAMPLE", "<datasample/>", xml=True, binary=(data,))

    async def add(
        self, payload: bytes = b"", params: Sequence[tuple[str, str]] = (), *, req: str = ""
    ) -> int:
        """ADD_SAMPLE; return the new id (Fail unless DATA_ACCEPTED with a decimal id)."""
        reply = await self.add_chunk(chunk(payload, params))
        return self.accepted_id(reply, "ADD_SAMPLE", req=req or "OA-STREAM-5")

    def accepted_id(self, reply: Message, what: str, *, req: str = "OA-STREAM-5") -> int:
        """Return the id of a DATA_ACCEPTED reply; Fail for anything else."""
        text = reply.content.strip()
        self.ctx.check(
            reply.type == "DATA_ACCEPTED" and text.isdigit(),
            f"{what} to {self.to} was answered {reply.type} {reply.content!r}",
            expected=f"DATA_ACCEPTED with the new sample's id as text ({req})",
        )
        return int(text)

    async def add_many(self, chunks: Sequence[bytes], *, req: str = "OA-STREAM-5") -> list[int]:
        """ADD_SAMPLES; return the new ids (Fail unless DATA_ACCEPTED with a collection)."""
        reply = await self.request("ADD_SAMPLES", samples_xml(len(chunks)), xml=True, binary=chunks)
        return self.collection_ids(reply, len(chunks), req=req)

    def collection_ids(self, reply: Message, count: int, *, req: str) -> list[int]:
        """Read `<collection><entry>id</entry>…</collection>` of a DATA_ACCEPTED reply."""
        want = f"DATA_ACCEPTED with <collection> of {count} <entry> ids ({req})"
        self.ctx.check(
            reply.type == "DATA_ACCEPTED",
            f"ADD_SAMPLES was answered {reply.type} {reply.content!r}",
            expected=want,
        )
        try:
            root = content_object(reply, "collection")
        except WakeupUnreadable as exc:
            self.ctx.fail(f"DATA_ACCEPTED content: {exc}", expected=want)
        texts = [(el.text or "").strip() for el in root if _local(el) == "entry"]
        self.ctx.check(
            len(texts) == count and all(t.isdigit() for t in texts),
            f"DATA_ACCEPTED lists {texts}",
            expected=want,
        )
        return [int(t) for t in texts]

    def refused(self, reply: Message, what: str, *, req: str) -> None:
        """Fail unless `reply` is DATA_NOT_ACCEPTED with SAMPLE_INVALID (OA-STREAM-5)."""
        check_error(
            self.ctx,
            reply,
            types=("DATA_NOT_ACCEPTED",),
            names=("SAMPLE_INVALID",),
            what=what,
            req=req,
        )

    # -- reading -----------------------------------------------------------------------------

    def sample_of(self, reply: Message, what: str, *, req: str = "OA-STREAM-6") -> Sample:
        """Read a DATASAMPLE reply or delivery: `<datasample/>` content and one chunk."""
        want = f"DATASAMPLE with <datasample/> content and one chunk ({req}, OA-STREAM-2)"
        self.ctx.check(
            reply.type == "DATASAMPLE",
            f"{what} was answered {reply.type} {reply.content!r}",
            expected=want,
        )
        try:
            content_object(reply, "datasample")
        except WakeupUnreadable as exc:
            self.ctx.fail(f"{what}: DATASAMPLE content: {exc}", expected=want)
        self.ctx.check(
            len(reply.binary) == 1,
            f"{what}: DATASAMPLE carries {len(reply.binary)} chunks",
            expected=want,
        )
        try:
            return read_chunk(reply.binary[0])
        except ValueError as exc:
            self.ctx.fail(f"{what}: the chunk is not a datasample: {exc}", expected=want)

    def samples_of(self, reply: Message, what: str, *, req: str) -> list[Sample]:
        """Read a DATASAMPLES reply: one `<object><datasample/></object>` per chunk."""
        want = f"DATASAMPLES with an <objectcollection> of datasamples and their chunks ({req})"
        self.ctx.check(
            reply.type == "DATASAMPLES",
            f"{what} was answered {reply.type} {reply.content!r}",
            expected=want,
        )
        try:
            root = content_object(reply, "objectcollection")
        except WakeupUnreadable as exc:
            self.ctx.fail(f"{what}: DATASAMPLES content: {exc}", expected=want)
        found = sum(1 for el in root.iter() if _local(el) == "datasample")
        self.ctx.check(
            found == len(reply.binary),
            f"{what}: {found} <datasample> elements but {len(reply.binary)} chunks",
            expected=want,
        )
        try:
            return [read_chunk(data) for data in reply.binary]
        except ValueError as exc:
            self.ctx.fail(f"{what}: a chunk is not a datasample: {exc}", expected=want)

    async def get(self, sample_id: int, *, req: str = "OA-STREAM-6") -> Sample:
        """GET_SAMPLE_BY_ID; Fail unless DATASAMPLE."""
        reply = await self.request("GET_SAMPLE_BY_ID", str(sample_id))
        return self.sample_of(reply, f"GET_SAMPLE_BY_ID {sample_id}", req=req)

    async def unknown(self, type: str, content: str = "", *, xml: bool = False, req: str) -> None:
        """Send a command that asks for a sample there is none of: RECEIVE_ERROR SAMPLE_UNKNOWN."""
        reply = await self.request(type, content, xml=xml)
        check_error(
            self.ctx, reply, names=("SAMPLE_UNKNOWN",), what=f"{type} {content}".strip(), req=req
        )

    async def newest_id(self) -> int:
        """Return the newest sample's id, 0 when the stream is empty (SAMPLE_UNKNOWN)."""
        reply = await self.request("GET_NEWEST_DATASAMPLE")
        if reply.type == "RECEIVE_ERROR" and error_name(reply.content) == "SAMPLE_UNKNOWN":
            return 0
        sample = self.sample_of(reply, "GET_NEWEST_DATASAMPLE")
        self.ctx.check(
            sample.id is not None,
            f"the newest sample has no builtin:id: {sample.params}",
            expected="builtin:id set by the stream (OA-STREAM-4)",
        )
        assert sample.id is not None
        return sample.id

    async def number(self, type: str, reply_type: str, *, req: str = "OA-STREAM-6") -> int:
        """Send GET_COUNT / GET_SIZE; return the decimal answer (Fail otherwise)."""
        reply = await self.request(type)
        text = reply.content.strip()
        self.ctx.check(
            reply.type == reply_type and text.isdigit(),
            f"{type} was answered {reply.type} {reply.content!r}",
            expected=f"{reply_type} with a decimal number ({req})",
        )
        return int(text)

    async def timestamp(self, type: str, *, req: str = "OA-STREAM-6") -> int:
        """Send GET_NEWEST_TIMESTAMP / GET_OLDEST_TIMESTAMP; return the time in ms."""
        reply = await self.request(type)
        want = f"TIMESTAMP with one time element <time sec msec/> ({req}, OA-TIME-1)"
        self.ctx.check(
            reply.type == "TIMESTAMP", f"{type} was answered {reply.type}", expected=want
        )
        try:
            roots = content_root(reply)
        except WakeupUnreadable as exc:
            self.ctx.fail(f"{type}: {exc}", expected=want)
        ms = read_time(roots[0]) if len(roots) == 1 else None
        self.ctx.check(ms is not None, f"{type} content is {reply.content!r}", expected=want)
        assert ms is not None
        return ms

    async def info(self, *, req: str) -> dict[str, str]:
        """Send GET_INFO; return the attributes of its `<streaminfo>` (lower-cased names)."""
        reply = await self.request("GET_INFO")
        want = f"INFO with one <streaminfo name … maxsize maxcount/> ({req})"
        self.ctx.check(reply.type == "INFO", f"GET_INFO was answered {reply.type}", expected=want)
        try:
            return attributes(content_object(reply, "streaminfo"))
        except WakeupUnreadable as exc:
            self.ctx.fail(f"GET_INFO content: {exc}", expected=want)

    async def send_binary(self, data: bytes) -> Message:
        """Send a BinaryM frame carrying `data`; return the next message (OA-STREAM-11)."""
        await self.raw.send_frame(Frame(tag=FrameTag.BINARY, chunks=(data,)))
        return await self.raw.read_message()


def read_time(el: etree._Element) -> int | None:
    """Return a time element's value in ms (sec, msec or ms; OA-TIME-1), or None if invalid."""
    attrs = attributes(el)
    sec = attrs.get("sec", "")
    msec = attrs.get("msec", attrs.get("ms", "0"))
    if not sec.lstrip("-").isdigit() or not msec.isdigit() or int(msec) > 999:
        return None
    return int(sec) * 1000 + int(msec)


def _local(el: etree._Element) -> str:
    return etree.QName(el).localname.lower() if isinstance(el.tag, str) else ""


def check_from(ctx: CaseContext, reply: Message, stream: str, what: str) -> None:
    """Fail unless a reply of the stream comes `from` the stream's name (streams contract)."""
    ctx.check(
        reply.sender == stream,
        f"{what}: the reply comes from {reply.sender!r}",
        expected=f"from = the stream's name {stream!r} (OA-STREAM-1)",
    )


def stored_params(
    params: Sequence[tuple[str, str]], sample_id: int, timestamp: int
) -> tuple[tuple[str, str], ...]:
    """Return the parameters a stream holds for a sample written with `params` (OA-STREAM-4).

    `builtin:id` and `builtin:timestamp` take the place of the writer's first parameter of
    that key (further ones removed), or are appended at the end, `builtin:id` first.
    """
    values = {"builtin:id": str(sample_id), "builtin:timestamp": str(timestamp)}
    out: list[tuple[str, str]] = []
    for key, value in params:
        if key in values:
            if any(k == key for k, _ in out):
                continue
            value = values[key]
        out.append((key, value))
    out += [(k, v) for k, v in values.items() if all(key != k for key, _ in out)]
    return tuple(out)


def check_sample(
    ctx: CaseContext,
    got: Sample,
    *,
    payload: bytes,
    params: Sequence[tuple[str, str]],
    sample_id: int,
    what: str,
    timestamp: int | None = None,
) -> None:
    """Fail unless `got` is the sample written: payload and parameters, with the id and the
    timestamp (`timestamp`, or any the stream chose when None) set by the stream (OA-STREAM-2,
    OA-STREAM-4)."""
    ctx.check(
        got.payload == payload,
        f"{what}: the payload came back as {len(got.payload)} bytes {got.payload[:40]!r}…",
        expected=f"the {len(payload)} payload bytes written, unchanged (OA-STREAM-2)",
    )
    stamps = [v for k, v in got.params if k == "builtin:timestamp"]
    ctx.check(
        len(stamps) == 1 and stamps[0].isdigit(),
        f"{what}: builtin:timestamp is {stamps}",
        expected="one builtin:timestamp, ms since the epoch (OA-STREAM-4)",
    )
    stamp = int(stamps[0]) if timestamp is None else timestamp
    want = stored_params(params, sample_id, stamp)
    ctx.check(
        got.params == want,
        f"{what}: the parameters came back as {got.params}",
        expected=f"{want}: the writer's parameters in order, builtin:id the id the stream gave "
        "and builtin:timestamp in place of the writer's first ones or appended (OA-STREAM-2, "
        "OA-STREAM-4)",
    )


async def stamped(client: StreamClient, base: int, dt: int) -> int:
    """Add a sample labelled T±dt with builtin:timestamp `base + dt`; return its id."""
    return await client.add(f"T{dt:+}".encode(), [("builtin:timestamp", str(base + dt))])


async def samples_by_time(
    ctx: CaseContext, client: StreamClient, base: int, span: tuple[int, int], want: list[int]
) -> None:
    """GET_SAMPLES_BY_TIME [T+start, T+end] answers the ids `want`."""
    start, end = span
    content = (
        f"<objectcollection><object>{time_xml(base + start)}</object>"
        f"<object>{time_xml(base + end)}</object></objectcollection>"
    )
    reply = await client.request("GET_SAMPLES_BY_TIME", content, xml=True)
    what = f"GET_SAMPLES_BY_TIME [T{start:+}, T{end:+}]"
    got = [s.id for s in client.samples_of(reply, what, req="OA-STREAM-6")]
    ctx.check(
        got == want,
        f"{what} answered {got}",
        expected=f"{want}: every held sample stamped within the range, by id (OA-STREAM-6)",
    )


async def holds_exactly(
    ctx: CaseContext,
    client: StreamClient,
    held: list[int],
    gone: Sequence[int],
    *,
    count_req: str,
    req: str,
    why: str,
    subject: str | None = None,
) -> None:
    """Fail unless the stream holds exactly the ids `held` (GET_COUNT under `count_req`,
    GET_SAMPLE_BY_ID of each under `req`) and none of `gone` (SAMPLE_UNKNOWN under `req`).

    The expectation reads "exactly the samples `held`" then `why`; the finding names the
    stream as `subject` (default: the stream's name).
    """
    count = await client.number("GET_COUNT", "COUNT", req=count_req)
    got = [(await client.get(i, req=req)).id for i in held]
    ctx.check(
        count == len(held) and got == held,
        f"{client.stream if subject is None else subject} holds {count} samples; "
        f"GET_SAMPLE_BY_ID of {held} found {got}",
        expected=f"exactly the samples {held}{why}",
    )
    for sample_id in gone:
        await client.unknown("GET_SAMPLE_BY_ID", str(sample_id), req=req)
