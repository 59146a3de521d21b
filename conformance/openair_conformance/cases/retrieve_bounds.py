"""Bounds on what retrieves return and what posts may hold (spec 14.1, issue #15): the count
bound of a wakeup's retrieves above the small integers (OA-LIM-9), and what eviction frees
under max-held-bytes (OA-LIM-14, OA-LIM-10).

LIM-040 runs at the default max-wakeup-results (1 000 posts, about a second). LIM-041 needs a
small max-held-bytes with max-history-bytes at most half of it and is not applicable, with that
reason, otherwise (`openair serve --max-held-bytes 262144 --max-history-bytes 131072`).
"""

from __future__ import annotations

from openair_conformance.cases._common import check_error, esc, triggers_xml, view_of
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import wakeup_trigger_id
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.registry import case

#: The largest max-wakeup-results LIM-040 fills (a post each).
_MAX_RESULTS = 4_096
#: The largest max-held-bytes LIM-041 fills.
_MAX_HELD = 4 * 1024 * 1024


async def _post(poster: TestModule, to: str, type_: str, content: str) -> str:
    await poster.post(to, type_, content)
    assert poster.last_sent is not None
    return poster.last_sent.id


#: A generous size of one of LIM-040's stored posts, envelope included (OA-LIM-14 counts it).
_HELD_NEEDED_PER_POST = 1024


@case(
    id="LIM-040",
    title="A wakeup whose first retrieve fills max-wakeup-results gets nothing of the second",
    section="14.1",
    requirements=("OA-LIM-9", "OA-WAKE-7", "OA-RET-12"),
    allowed=(
        "exactly max-wakeup-results messages, all of the first retrieve, newest first; none of "
        "the second retrieve's",
    ),
)
async def wakeup_results_filled(ctx: CaseContext) -> None:
    """Register Go with a retrieve of A then one of B; post max-wakeup-results A messages and
    one B message to WB2, then Go.

    Catches: a count bound checked by identity (`len(results) is max_count`, issue #15), which
    holds for small bounds only: at the default 1 000 the second retrieve then runs with no
    bound left and the wakeup carries more than max-wakeup-results messages.
    """
    limit = ctx.server.limit("max-wakeup-results", 1_000)
    if limit > _MAX_RESULTS:
        raise NotApplicable(
            f"max-wakeup-results is {limit}; run against a server advertising at most "
            f"{_MAX_RESULTS} (the default is 1000)"
        )
    # Its posts stay stored (about 600 bytes each): a server holding far less refuses them
    # rightly (OA-LIM-14), and other cases post beside it.
    held = ctx.server.limit("max-held-bytes", 1 << 30)
    if held < _HELD_NEEDED_PER_POST * (limit + 2) * 4:
        raise NotApplicable(
            f"max-held-bytes is {held}; the case stores {limit + 2} posts and needs a server "
            f"holding at least four times their {_HELD_NEEDED_PER_POST * (limit + 2)} bytes"
        )
    reader = await ctx.module("Reader")
    poster = await ctx.module("Poster", bind=False)
    go, a, b = ctx.type("Go"), ctx.type("A"), ctx.type("B")

    def retrieve(pattern: str) -> str:
        return f'<retrieve from="WB2" type="{esc(pattern)}"><latest>0</latest></retrieve>'

    registration = f"{triggers_xml(go, wb='WB2')}<retrieves>{retrieve(a)}{retrieve(b)}</retrieves>"
    await reader.subscribe(registration, check=True)
    a_ids = [await _post(poster, "WB2", a, "") for _ in range(limit)]
    b_id = await _post(poster, "WB2", b, "")
    trigger = await _post(poster, "WB2", go, "go")
    wakeup = await reader.expect_wakeup(
        lambda w: wakeup_trigger_id(w) == trigger, timeout=ctx.deadline * 4
    )
    got = [m.id for m in view_of(ctx, wakeup).retrieved]
    want = a_ids[::-1]
    ctx.check(
        len(got) <= limit,
        f"the wakeup retrieved {len(got)} messages ({got.count(b_id)} of B)",
        expected=f"at most max-wakeup-results ({limit}) (OA-LIM-9)",
    )
    ctx.check(
        got == want,
        f"the wakeup retrieved {len(got)} messages, not the {limit} A messages newest first",
        expected=f"the {limit} A messages, newest first, and not B (OA-LIM-9, OA-RET-12)",
    )


@case(
    id="LIM-041",
    title="Under max-held-bytes, what a post evicts counts as freed; past it, a post is refused",
    section="14.1",
    requirements=("OA-LIM-14", "OA-LIM-10"),
    serial=True,  # it fills the server-wide max-held-bytes
    residue=True,  # and leaves it full: it runs after every other case
    allowed=(
        "every post to WB1 and WB2 accepted (each keeps at most max-history-bytes, at most half "
        "of max-held-bytes), then a post to AIRCentral that takes the text alone past "
        "max-held-bytes answered RECEIVE_ERROR 'LIMIT_EXCEEDED: …'",
    ),
)
async def held_freed(ctx: CaseContext) -> None:
    """Fill WB1 and WB2 past max-history-bytes (H) with posts of H/8, then post H/2 to each:
    all must be accepted, as each board then holds at most H and 2H fits max-held-bytes.
    Then post to AIRCentral what takes the newest copies' text past max-held-bytes: refused.

    Catches: eviction not counted as freed (issue #15: `board.bytes + size >> max_bytes`
    survived), and a bound summed with a bitwise slip (`held | size <= limit` survived: below
    a power-of-two bound the OR of two sizes never passes it).
    """
    limit = ctx.server.limit("max-held-bytes", 1 << 30)
    history = ctx.server.limit("max-history-bytes", 256 * 1024 * 1024)
    if limit > _MAX_HELD or not history or 2 * history > limit or history < 8 * 1024:
        raise NotApplicable(
            f"max-held-bytes is {limit} and max-history-bytes {history}; run against a server "
            f"advertising at most {_MAX_HELD} and at most half of it (openair serve "
            "--max-held-bytes 262144 --max-history-bytes 131072)"
        )
    poster = await ctx.module("Poster", bind=False)
    each, half = history // 8, history // 2
    fill = ctx.type("Fill")
    for board in ("WB1", "WB2"):
        for n in range(12):  # 1.5 H: the oldest are evicted (OA-LIM-10)
            reply = await poster.post(board, fill, "f" * each, check=False)
            ctx.check(
                reply.type == "RECEIVE_ACCEPT",
                f"post {n + 1} of {each} bytes to {board} was answered {reply.type} "
                f"{reply.content!r}",
                expected=f"RECEIVE_ACCEPT: each board keeps at most {history} bytes and "
                f"both fit max-held-bytes ({limit}) (OA-LIM-10, OA-LIM-14)",
            )
    for board in ("WB1", "WB2"):
        reply = await poster.post(board, ctx.type("Half"), "h" * half, check=False)
        ctx.check(
            reply.type == "RECEIVE_ACCEPT",
            f"a post of {half} bytes to the full {board} was answered {reply.type} "
            f"{reply.content!r}",
            expected=f"RECEIVE_ACCEPT: what it evicts from {board} counts as freed, and both "
            f"boards then hold at most {2 * history} <= {limit} bytes (OA-LIM-14)",
        )
    # The newest copies of WB1 and WB2 alone hold 2 * half bytes of text.
    size = limit - 2 * half + 1024
    if size <= 0:
        raise Inconclusive(f"max-held-bytes {limit} leaves no room for the last post")
    reply = await poster.post("AIRCentral", ctx.type("Over"), "o" * size, check=False)
    ctx.check(
        reply.type != "RECEIVE_ACCEPT",
        f"a post of {size} bytes to AIRCentral, while WB1 and WB2 keep at least {2 * half} "
        f"bytes of text, was accepted",
        expected=f"refused: it would take the bytes held past max-held-bytes ({limit}) (OA-LIM-14)",
    )
    check_error(
        ctx, reply, names=("LIMIT_EXCEEDED",), what="a post past the bound", req="OA-LIM-14"
    )
