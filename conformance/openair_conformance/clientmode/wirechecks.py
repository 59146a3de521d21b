"""Checks of what a library put on the wire during one scenario (schemas/scenario.xsd, `<wire>`).

Each check reads the `Capture` of the scenario and returns the `Problem`s it found, each citing
the requirement it breaks and the trace entry that shows it (the report's divergence). The
checks are independent of the library's own view: they work on the bytes the tap recorded.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache

from lxml import etree

from openair.protocol.errors import OpenAIRError
from openair.protocol.framing import FrameTag
from openair.protocol.xmlsafe import local_name, parse_xml
from openair.resources import schema_path
from openair_conformance.clientmode.tap import Capture, ConnKind, WireFrame

__all__ = ["CHECKS", "Problem", "WireContext", "run_checks"]

_NS_PER_S = 1_000_000_000
_AHEAD_NS = _NS_PER_S  # a postedTime this far after the frame arrived is in the future


@dataclass(frozen=True, slots=True, kw_only=True)
class Problem:
    """One violation: the check, the requirement, what happened, where in the trace."""

    check: str
    requirement: str
    text: str
    trace_index: int | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class WireContext:
    """What the checks need besides the capture."""

    module: str
    advertised: frozenset[str]
    stamp_window_s: float = 2.0  # OA-TIME-2: how long before sending a stamp may be taken
    final: bool = True  # False while the scenario still runs: unanswered is not yet a fault


@cache
def _message_schema() -> etree.XMLSchema:
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    return etree.XMLSchema(etree.parse(str(schema_path("message.xsd")), parser))


def _messages(capture: Capture) -> list[WireFrame]:
    return [f for f in capture.library_frames() if f.frame.tag is not FrameTag.BINARY]


def _describe(f: WireFrame) -> str:
    kind = f.message.type if f.message is not None else "an undecodable message"
    return f"{kind} on {f.conn.label}"


def check_decodes(capture: Capture, ctx: WireContext) -> list[Problem]:
    """OA-MSG-1: every frame the library sent is well framed and its message decodes."""
    found = [
        Problem(check="decodes", requirement="OA-MSG-1", text=text, trace_index=index)
        for text, index in capture.problems
        if text.startswith("framing error")
    ]
    for f in _messages(capture):
        if f.message is None:
            text = f"the library sent a message that does not decode: {f.error}"
            found.append(Problem(check="decodes", requirement="OA-MSG-1", text=text,
                                 trace_index=f.trace_index))  # fmt: skip
    return found


def _invalid(schema: etree.XMLSchema, root: etree._Element) -> str:
    """What makes `root` not a canonical message (empty when it is one)."""
    if root.tag != "message":
        return f"the root element is <{root.tag}>, not <message>"
    try:
        schema.assertValid(root)
    except etree.DocumentInvalid as exc:
        return str(exc)
    return ""


def check_canonical(capture: Capture, ctx: WireContext) -> list[Problem]:
    """OA-MSG-4: every message validates against schemas/message.xsd (canonical form)."""
    schema = _message_schema()
    found = []
    for f in _messages(capture):
        try:
            root = parse_xml(f.frame.xml)
        except OpenAIRError as exc:
            found.append(Problem(check="canonical", requirement="OA-MSG-1",
                                 text=f"{_describe(f)} is not XML: {exc}",
                                 trace_index=f.trace_index))  # fmt: skip
            continue
        problem = _invalid(schema, root)
        if not problem:
            continue
        found.append(Problem(check="canonical", requirement="OA-MSG-4",
                             text=f"{_describe(f)} is not in canonical form: {problem}",
                             trace_index=f.trace_index))  # fmt: skip
    return found


def check_posted_time(capture: Capture, ctx: WireContext) -> list[Problem]:
    """OA-TIME-2: every message carries a postedTime taken just before it was sent."""
    found = []
    window_ns = int(ctx.stamp_window_s * _NS_PER_S)
    for f in _messages(capture):
        msg = f.message
        if msg is None:
            continue
        if msg.posted is None:
            text = f"{_describe(f)} carries no postedTime"
        else:
            posted_ns = msg.posted.us * 1000
            if posted_ns > f.wall_ns + _AHEAD_NS:
                text = f"{_describe(f)}: postedTime {msg.posted} is after the frame arrived"
            elif posted_ns < f.wall_ns - window_ns:
                late = (f.wall_ns - posted_ns) / 1e6
                text = f"{_describe(f)}: postedTime was stamped {late:.0f} ms before it was sent"
            else:
                continue
        found.append(Problem(check="posted-time", requirement="OA-TIME-2", text=text,
                             trace_index=f.trace_index))  # fmt: skip
    return found


def check_callback_opened(capture: Capture, ctx: WireContext) -> list[Problem]:
    """OA-SESS-7, OA-FRAME-10: a Receive frame opened the callback connection, and nothing else."""
    found = []
    firsts: dict[int, WireFrame] = {}
    for f in capture.library_frames():
        first = firsts.setdefault(f.conn.number, f)
        if f.frame.tag is not FrameTag.RECEIVE:
            continue
        msg = f.message
        if first is not f:
            text = f"a Receive frame that is not the first frame of {f.conn.label}"
        elif msg is None or msg.type != "RECEIVE_NAME_NOTIFICATION":
            text = f"a Receive frame carrying {_describe(f)}, not RECEIVE_NAME_NOTIFICATION"
        elif msg.sender != ctx.module:
            text = f"the Receive frame names {msg.sender!r}, not the module {ctx.module!r}"
        else:
            continue
        found.append(Problem(check="callback-opened", requirement="OA-FRAME-10", text=text,
                             trace_index=f.trace_index))  # fmt: skip
    if ctx.final and not any(c.kind is ConnKind.CALLBACK for c in capture.conns):
        found.append(Problem(check="callback-opened", requirement="OA-SESS-7",
                             text="the library never opened a callback connection "
                                  "(no connection began with a Receive frame)"))  # fmt: skip
    return found


def _ack_requirement(request_type: str) -> str:
    return {"PING": "OA-SESS-11", "KEEPALIVE": "OA-KEEP-2"}.get(request_type, "OA-DELIV-4")


def check_acks(capture: Capture, ctx: WireContext) -> list[Problem]:
    """Every request to the module answered, in order, with the right type and isresponse."""
    found = [
        Problem(check="acks", requirement="OA-SESS-28", text=text, trace_index=index)
        for text, index in capture.problems
        if "may only answer" in text
    ]
    for record in capture.acks:
        request = record.request.message
        kind = request.type if request is not None else "an undecodable request"
        where = f"{kind} on {record.conn.label}"
        answer = record.answer
        requirement = _ack_requirement(request.type if request is not None else "")
        if answer is None:
            if not ctx.final or (record.conn.closed and record.conn.closed_by != "library"):
                continue  # the peer closed first: nobody could answer
            text = f"{where} was never answered"
            index = record.request.trace_index
        elif answer.message is None:
            text, index = f"the answer to {where} does not decode", answer.trace_index
        elif answer.message.type != record.expected_type:
            text = f"{where} was answered {answer.message.type}, not {record.expected_type}"
            index = answer.trace_index
        elif request is not None and answer.message.isresponse != request.id:
            requirement = "OA-SESS-2"
            text = (
                f"the answer to {where} has isresponse {answer.message.isresponse!r}, not its id "
                f"{request.id!r} (a wrong isresponse, or answers out of order)"
            )
            index = answer.trace_index
        else:
            continue
        found.append(Problem(check="acks", requirement=requirement, text=text, trace_index=index))
    return found


def _envelope_attr(f: WireFrame, name: str) -> bool:
    """Whether the root or a direct child of the message carries attribute `name` (any case)."""
    try:
        root = parse_xml(f.frame.xml)
    except OpenAIRError:
        return False
    for el in (root, *(c for c in root if isinstance(c.tag, str) and local_name(c) != "content")):
        if any(str(key).lower() == name for key in el.attrib):
            return True
    return False


def check_extensions(capture: Capture, ctx: WireContext) -> list[Problem]:
    """OA-GEN-2: no wire form of an extension the server did not advertise."""
    found = []
    forms = (("noreply", "noreply", "a noreply attribute"), ("usec", "usec", "a usec attribute"))
    for f in _messages(capture):
        for extension, attribute, what in forms:
            if extension not in ctx.advertised and _envelope_attr(f, attribute):
                text = (
                    f"{_describe(f)} carries {what}, but the server did not advertise {extension}"
                )
                found.append(Problem(check="extensions", requirement="OA-GEN-2", text=text,
                                     trace_index=f.trace_index))  # fmt: skip
        msg = f.message
        if msg is not None and msg.type == "GET_TIME" and "gettime" not in ctx.advertised:
            found.append(Problem(check="extensions", requirement="OA-GEN-2",
                                 text="GET_TIME sent to a server that did not advertise gettime",
                                 trace_index=f.trace_index))  # fmt: skip
    if "pipelining" not in ctx.advertised:
        for conn in capture.conns:
            if conn.kind is ConnKind.PRIMARY and conn.max_in_flight > 1:
                text = (
                    f"{conn.max_in_flight} requests in flight on {conn.label}, but the server did "
                    "not advertise pipelining (OA-SESS-18)"
                )
                found.append(Problem(check="extensions", requirement="OA-GEN-2", text=text,
                                     trace_index=conn.pipelined_at))  # fmt: skip
    return found


CHECKS: dict[str, Callable[[Capture, WireContext], list[Problem]]] = {
    "decodes": check_decodes,
    "canonical": check_canonical,
    "posted-time": check_posted_time,
    "callback-opened": check_callback_opened,
    "acks": check_acks,
    "extensions": check_extensions,
}


def run_checks(names: Sequence[str], capture: Capture, ctx: WireContext) -> list[Problem]:
    """Run the named checks and return every problem, in check order."""
    return [problem for name in names for problem in CHECKS[name](capture, ctx)]
