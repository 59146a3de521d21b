"""Cases at the exact edge of two 14.1 bounds (issue #15): the number of streams created at run
time (OA-LIM-17) and the attachment bytes of a retrieve reply (OA-RET-15).

Both run when the server advertises small limits and are not applicable, with that reason,
otherwise: at the defaults (64 streams, 64 MiB) reaching the bound takes too long or, for the
streams, spends a budget that the other stream cases of the run need. Run them on their own
against servers started with `max-created-streams` 4 (LIM-050) and `max-frame-binary` 4096
(LIM-051).
"""

from __future__ import annotations

import re

from openair.protocol.message import Message
from openair_conformance.cases._common import check_error
from openair_conformance.cases._streams import create_stream_request
from openair_conformance.cases.attachments import nested_attachments
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
)
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

_TYPED = ("typed-streams",)
#: The largest max-created-streams LIM-050 spends.
_MAX_CREATED = 16
#: The largest max-frame-binary LIM-051 fills with one post.
_MAX_BINARY = 1024 * 1024
#: The names this suite gives (CaseContext.name): a stream so named that is listed before LIM-050
#: creates any was created by an earlier run; the others are taken to be the configuration's.
_SUITE_NAME = re.compile(r"^C[0-9A-Za-z]+_[A-Z]+[0-9]+_")


@case(
    id="LIM-050",
    title="Exactly max-created-streams streams can be created at run time, then LIMIT_EXCEEDED",
    section="14.1",
    requirements=("OA-LIM-17", "OA-XSTREAM-10"),
    needs=_TYPED,
    serial=True,
    allowed=(
        "with max-created-streams N (at most 16) and no stream created by an earlier run: N "
        "creations are answered RECEIVE_ACCEPT, the next RECEIVE_ERROR LIMIT_EXCEEDED naming "
        "max-created-streams (the configuration's streams do not count)",
    ),
)
async def created_streams_count(ctx: CaseContext) -> None:
    """Read max-created-streams N (CAPABILITIES); list the streams (GET_STREAMS); create streams
    until one is refused. The refusal must be LIMIT_EXCEEDED naming the limit, after exactly N
    creations. Streams listed before with the names this suite gives were created by an earlier
    run: then at least N minus those must be accepted, and fewer than N is inconclusive; the
    other streams listed are taken to be the configuration's, which do not count.

    Catches: a count of created streams that grows by more than one a creation (the limit hit
    early), or one checked with the wrong comparison (one too few or too many).
    """
    limit = ctx.server.limit("max-created-streams", 64)
    if limit > _MAX_CREATED:
        raise NotApplicable(
            f"max-created-streams is {limit}; spending it would starve the other stream cases"
        )
    raw = await ctx.raw("Creator")
    reply = await raw.request(Message(type="GET_STREAMS", sender=ctx.name("Creator"), to="CNS"))
    try:
        listed = [
            attributes(el).get("name")
            for el in content_object(reply, "streams")
            if isinstance(el.tag, str)
        ]
    except WakeupUnreadable as exc:
        raise Inconclusive(f"setup: GET_STREAMS was answered {reply.type}: {exc}") from exc
    accepted = 0
    refusal: Message | None = None
    for n in range(limit + 1):
        name = ctx.name(f"Made{n}")
        content = f'<stream name="{name}" whiteboard="WB1" idle="0"/>'
        reply = await raw.request(create_stream_request(ctx, content))
        if reply.type != "RECEIVE_ACCEPT":
            refusal = reply
            break
        accepted += 1
    what = f"creation {accepted + 1} of a stream (max-created-streams {limit})"
    if refusal is None:
        ctx.fail(
            f"{limit + 1} streams were created at run time",
            expected=f"the creation after the {limit}th refused (OA-LIM-17)",
        )
    check_error(ctx, refusal, names=("LIMIT_EXCEEDED",), what=what, req="OA-LIM-17")
    ctx.check(
        "max-created-streams" in refusal.content,
        f"{what}: the refusal is {refusal.content!r}",
        expected="the refusal names the limit max-created-streams (OA-LIM-17)",
    )
    earlier = [name for name in listed if name and _SUITE_NAME.match(name)]
    if earlier and limit - len(earlier) <= accepted < limit:
        raise Inconclusive(
            f"{accepted} of {limit} creations accepted; {len(earlier)} streams named by this "
            "suite were listed before: earlier runs created them"
        )
    ctx.check(
        accepted == limit,
        f"{accepted} streams were created before the refusal; listed before: {listed}",
        expected=f"{limit}: as many as max-created-streams, the streams of the configuration "
        "not counting (OA-LIM-17)",
    )


@case(
    id="LIM-051",
    title="A retrieve reply whose attachments total exactly max-frame-binary is sent",
    section="9.3",
    requirements=("OA-RET-15", "OA-RET-19", "OA-WB-13"),
    allowed=(
        "with max-frame-binary B (at most 1 MiB): a post with one chunk of B bytes is accepted, "
        "and a retrieve of it is AIR.Retrieve.Success carrying that chunk",
    ),
)
async def retrieve_at_binary_limit(ctx: CaseContext) -> None:
    """Post a message with one chunk of exactly max-frame-binary bytes; retrieve it.

    Catches: a retrieve bound on attachments checked with >= (a reply of exactly the limit,
    which OA-RET-15 allows, refused LIMIT_EXCEEDED).
    """
    limit = ctx.server.limit("max-frame-binary", 64 * 1024 * 1024)
    if limit > _MAX_BINARY:
        raise NotApplicable(f"max-frame-binary is {limit}; too large to fill quickly")
    poster = await ctx.module("Poster", bind=False)
    chunk = b"e" * limit
    msg = Message(
        type=ctx.type("Edge"), sender=poster.name, to="WB1", content="Edge", binary=(chunk,)
    )
    reply = await poster.request(msg)
    if reply.type != "RECEIVE_ACCEPT" or poster.last_sent is None:
        raise Inconclusive(f"setup: a post of {limit} bytes was answered {reply.type}")
    posted = poster.last_sent.id
    pattern = ctx.type("*")
    reply = await poster.retrieve(
        f'<retrieve from="WB1" type="{pattern}"><latest>0</latest></retrieve>'
    )
    what = f"a retrieve of one message with a chunk of max-frame-binary ({limit}) bytes"
    ctx.check(
        reply.type == "AIR.Retrieve.Success",
        f"{what} was answered {reply.type} {reply.content[:200]!r}",
        expected="AIR.Retrieve.Success: chunks totalling the limit do not exceed it (OA-RET-15)",
    )
    try:
        got = nested_attachments(reply)
    except (WakeupUnreadable, ValueError) as exc:
        ctx.fail(f"{what}: {exc}", expected="chunks laid out as OA-RET-19 says")
    ctx.check(
        got == [(posted, (chunk,))],
        f"{what}: the reply holds {[(i, [len(c) for c in cs]) for i, cs in got]}",
        expected=f"the posted message with its one chunk of {limit} bytes (OA-RET-19)",
    )
