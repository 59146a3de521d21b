"""Conformance cases for time lookups at their boundaries (spec 11.4, issue #15).

Timestamps are the writer's (`builtin:timestamp`): they need not rise with the sample ids, and
several samples may share one. GET_SAMPLE_BY_TIME then answers the sample with the greatest
timestamp at or before the time, the newest of those on a tie (the table of 11.4).
"""

from __future__ import annotations

from openair_conformance.cases._streams import (
    StreamClient,
    marker,
    past_window,
    stream_under_test,
    time_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case


@case(
    id="STREAM-040",
    title="GET_SAMPLE_BY_TIME over falling and equal timestamps: the newest on a tie",
    section="11.4",
    requirements=("OA-STREAM-6",),
    allowed=(
        "samples added stamped T+40, T+30, T+30: at T+35 the second T+30 one (the newest of "
        "the tie), at T+45 the T+40 one",
    ),
)
async def time_lookup_ties(ctx: CaseContext) -> None:
    """Add samples stamped T+40, T+30 and T+30 (T a window unique to the case); look up T+35
    and T+45.

    Catches: the oldest sample of a tie instead of the newest, a lookup that assumes the
    timestamps rise with the ids (a binary search over falling times).
    """
    stream = await stream_under_test(ctx)
    reader = await StreamClient.open(ctx, stream, "R")
    base = past_window(ctx)
    ids = [
        await reader.add(f"at +{dt}".encode(), [("builtin:timestamp", str(base + dt)), marker(ctx)])
        for dt in (40, 30, 30)
    ]
    for dt, want, what in ((35, ids[2], "the second T+30 sample"), (45, ids[0], "the T+40 one")):
        reply = await reader.request("GET_SAMPLE_BY_TIME", time_xml(base + dt), xml=True)
        got = reader.sample_of(reply, f"GET_SAMPLE_BY_TIME T+{dt}")
        ctx.check(
            got.id == want,
            f"GET_SAMPLE_BY_TIME T+{dt} answered sample {got.id} stamped T+"
            f"{(got.timestamp or 0) - base} (added: {ids})",
            expected=f"sample {want}, {what}: the greatest timestamp at or before t, the newest "
            "on a tie (OA-STREAM-6)",
        )
