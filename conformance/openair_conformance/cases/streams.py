"""Stream cases (spec section 11) that every server is judged on: a server without streams
answers media commands as for an unknown stream (OA-GEN-4, OA-STREAM-3).

The stream model itself (samples, reading, waiting, push and the typed-streams extension) is
checked by the streams work of the kit against servers that offer streams.
"""

from __future__ import annotations

from openair.message import Message
from openair_conformance.cases._common import check_error
from openair_conformance.harness import CaseContext
from openair_conformance.registry import case

#: Media commands of 11.3–11.5 that need no content to be recognised.
_MEDIA_COMMANDS = ("GET_COUNT", "GET_NEWEST_DATASAMPLE", "GET_OLDEST_TIMESTAMP", "GET_SIZE")


@case(
    id="STREAM-001",
    title="A media command to a name that is no stream is answered STREAM_UNKNOWN",
    section="11.1",
    requirements=("OA-STREAM-3", "OA-GEN-4", "OA-ERR-6"),
    allowed=("RECEIVE_ERROR with content 'STREAM_UNKNOWN: detail' (not FORWARD_FAILED)",),
)
async def media_command_unknown_stream(ctx: CaseContext) -> None:
    """Send GET_COUNT, GET_NEWEST_DATASAMPLE, GET_OLDEST_TIMESTAMP and GET_SIZE to a name no
    component, whiteboard, stream or module has.

    Catches: media commands routed like posts (FORWARD_FAILED), which gives a stream client no
    way to tell a missing stream from a missing module.
    """
    raw = await ctx.raw()
    to = ctx.name("NoStream")
    for command in _MEDIA_COMMANDS:
        reply = await raw.request(Message(type=command, sender=ctx.name("S"), to=to))
        check_error(
            ctx, reply, names=("STREAM_UNKNOWN",), what=f"{command} to {to}", req="OA-STREAM-3"
        )
