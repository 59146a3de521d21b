"""Which slots the byte bound of a wakeup's retrieves counts (spec 14.1, OA-LIM-9, issue #15).

OA-LIM-9 counts a retrieved message's `content`, `comment` and `history` together, so a peer
cannot pass the bound with short contents and long comments. Like LIM-001..004 it runs when the
server advertises small bounds (`openair serve --max-wakeup-result-bytes 5 --max-wakeup-results
8`) and is not applicable otherwise.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import esc, triggers_xml, view_of
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import wakeup_trigger_id
from openair_conformance.model import NotApplicable
from openair_conformance.registry import case

_MAX_RESULT_BYTES = 64


@case(
    id="LIM-005",
    title="A wakeup's byte bound counts each retrieved message's comment with its content",
    section="14.1",
    requirements=("OA-LIM-9", "OA-WAKE-7"),
    allowed=(
        "with a one-character content and a one-character comment each: exactly "
        "min(max-wakeup-results, max-wakeup-result-bytes // 2) messages, the newest first",
    ),
)
async def wakeup_result_bytes_comment(ctx: CaseContext) -> None:
    """Register Go with a retrieve of A; post max-wakeup-result-bytes A messages of content
    `x` and comment `y` (two text bytes each), then Go.

    Catches: a byte bound that counts the content only (or the comment only), or that combines
    the slots' sizes other than by their sum.
    """
    size = ctx.server.limit("max-wakeup-result-bytes", 4 * 1024 * 1024)
    count = ctx.server.limit("max-wakeup-results", 1_000)
    if size > _MAX_RESULT_BYTES or size < 4:
        raise NotApplicable(
            f"max-wakeup-result-bytes is {size}; run against a server advertising 4 to "
            f"{_MAX_RESULT_BYTES} (openair serve --max-wakeup-result-bytes 5)"
        )
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    go, a = ctx.type("Go"), ctx.type("A")
    retrieve = f'<retrieve from="WB1" type="{esc(a)}"><latest>0</latest></retrieve>'
    await reader.subscribe(f"{triggers_xml(go)}<retrieves>{retrieve}</retrieves>", check=True)
    sent: list[str] = []
    for _ in range(size):
        msg = Message(type=a, sender=poster.name, to="WB1", content="x", comment="y")
        reply = await poster.request(msg)
        if reply.type != "RECEIVE_ACCEPT":
            ctx.fail(
                f"the post of {a} with a comment was answered {reply.type} {reply.content!r}",
                expected="RECEIVE_ACCEPT (OA-WB-3)",
            )
        assert poster.last_sent is not None
        sent.append(poster.last_sent.id)
    await poster.post("WB1", go, "go")
    assert poster.last_sent is not None
    trigger = poster.last_sent.id
    wakeup = await reader.expect_wakeup(lambda w: wakeup_trigger_id(w) == trigger)
    got = [m.id for m in view_of(ctx, wakeup).retrieved]
    want = sent[::-1][: min(size // 2, count)]
    ctx.check(
        got == want,
        f"the wakeup retrieved {len(got)} messages {got}",
        expected=f"the {len(want)} newest {want}: two text bytes each, content and comment "
        "(OA-LIM-9)",
    )
