"""The scenario steps of streams and attachments: `call`, `require`, `kit-create-stream`,
`kit-stream-add` (schemas/scenario.xsd, shim/PROTOCOL.md "Streams and attachments").

`call` sends any shim command with JSON fields. The stream commands are optional in
`openair-shim/1`: a shim that answers one of them API_MISUSE "unknown command …" (or a post with
attachments API_MISUSE "unsupported field …") has a library without that part, and the scenario
is reported not-applicable, never a pass. `require` makes a scenario not-applicable when the
server does not advertise an extension. The kit's own stream steps write samples and create
streams on the kit's connection straight to the server, so that the library has something to
read, wait for or be pushed.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import json
from collections.abc import Awaitable, Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from openair.client.stream_wire import add_sample_request
from openair.protocol.attachments import parse_results
from openair.protocol.content import RetrieveSpec
from openair.protocol.datasample import DataSample, encode_chunk
from openair.protocol.errors import OpenAIRError
from openair.protocol.message import Message
from openair.protocol.objects import element, serialize
from openair.protocol.registration import encode_retrieve
from openair_conformance.clientmode.values import MISSING, Values, lookup
from openair_conformance.model import Inconclusive, NotApplicable
from openair_conformance.shim.driver import STREAM_COMMANDS, ShimError

if TYPE_CHECKING:
    from openair_conformance.clientmode.runner import ScenarioRun
    from openair_conformance.clientmode.scenario import Step

__all__ = ["ATTACHMENTS", "SERVER_LACKS", "expand_json", "not_applicable", "stream_steps"]

COMMAND_S = 15.0  # as runner.COMMAND_S: the library's request timeout plus a margin
ATTACHMENTS = "attachments"
#: The start of the not-applicable message when the kit's server lacks what a scenario needs.
SERVER_LACKS = "the server does not keep"


def expand_json(value: Any, values: Values) -> Any:
    """Expand placeholders in every string of a JSON value.

    A string that is exactly one `{NAME.PATH}` placeholder becomes the saved value itself (a
    number stays a number); other strings are expanded as text.
    """
    if isinstance(value, str):
        inner = value[1:-1]
        whole = value.startswith("{") and value.endswith("}") and not {"{", "}"} & set(inner)
        if whole and "." in inner:
            name, _, path = inner.partition(".")
            found = lookup(values.get(name), path)
            if found is not MISSING and not isinstance(found, str):
                return found
        return values.expand(value)
    if isinstance(value, list):
        return [expand_json(v, values) for v in value]
    if isinstance(value, dict):
        return {k: expand_json(v, values) for k, v in value.items()}
    return value


def not_applicable(cmd: str, answer: dict[str, Any]) -> NotApplicable | None:
    """The not-applicable verdict an API_MISUSE answer means (PROTOCOL.md), or None."""
    if answer.get("ok") is not False:
        return None
    error = answer.get("error", {})
    message = str(error.get("message", "")).strip().lower()
    if error.get("code") != "API_MISUSE":
        return None
    if cmd in STREAM_COMMANDS and message.startswith("unknown command"):
        return NotApplicable(f"the shim does not offer streams ({cmd}: {error.get('message')})")
    if message.startswith("unsupported field"):
        return NotApplicable(f"the shim does not offer {cmd} with {error.get('message')}")
    return None


def _timeout(run: ScenarioRun, args: dict[str, Any]) -> float:
    waited = args.get("timeout_ms", 0)
    extra = waited / 1000 if isinstance(waited, (int, float)) else 0.0
    return (COMMAND_S + extra) * run.scale


async def _call(run: ScenarioRun, step: Step) -> None:
    """Send `cmd` with `args`; not-applicable for a part the shim lacks; judge and check."""
    assert run.driver is not None
    cmd = step.get("cmd")
    try:
        raw = json.loads(step.get("args", "{}"))
    except ValueError as exc:
        raise ValueError(f"call (line {step.line}): args is not JSON: {exc}") from exc
    if not isinstance(raw, dict) or {"seq", "cmd"} & set(raw):
        raise ValueError(f"call (line {step.line}): args must be a JSON object without seq, cmd")
    args = expand_json(raw, run.values)
    try:
        answer = await run.driver.command(cmd, args, _timeout(run, args))
    except ShimError as exc:
        raise run._fail(f"{cmd} (line {step.line}): {exc}") from exc
    missing = not_applicable(cmd, answer)
    if missing is not None:
        raise missing
    run._judge_outcome(step, cmd, answer)
    run._check(step, {k: v for k, v in answer.items() if k not in ("seq", "ok")})


_PROBE_CHUNK = b"\x00\x01probe\xff"


async def _require(run: ScenarioRun, step: Step) -> None:
    """Not-applicable unless the server has `feature` (attachments: keeps them, probed)."""
    assert run.peer is not None
    feature = step.get("feature")
    if feature == ATTACHMENTS:
        await _require_attachments(run)
    elif feature not in run.peer.advertised:
        raise NotApplicable(f"the server does not advertise {feature}")


async def _require_attachments(run: ScenarioRun) -> None:
    """Post one chunk on the kit's connection and read it back (OA-WB-13, OA-RET-19)."""
    assert run.kit is not None
    kind = run.values.expand("{T}.Probe.Attachments")
    post = Message(type=kind, sender=run.kit.name, to="WB1", binary=(_PROBE_CHUNK,))
    _, reply = await run.kit.request(post)
    if reply.type != "RECEIVE_ACCEPT":
        raise NotApplicable(f"the server refuses a post with attachments ({reply.type})")
    ask = Message(type="AIR.Retrieve", sender=run.kit.name, to="WB1", language="xml",
                  content=encode_retrieve(RetrieveSpec(whiteboard="WB1", pattern=kind)),
                  content_is_xml=True)  # fmt: skip
    _, found = await run.kit.request(ask)
    try:
        kept = found.type == "AIR.Retrieve.Success" and any(
            m.binary == (_PROBE_CHUNK,) for m in parse_results(found)
        )
    except OpenAIRError:
        kept = False
    if not kept:
        raise NotApplicable(f"{SERVER_LACKS} attachments: a post's chunk did not come back")


async def _create_stream(run: ScenarioRun, step: Step) -> None:
    """Create a stream at run time (OA-XSTREAM-10); Inconclusive when the server refuses."""
    assert run.kit is not None
    attrs = [("name", run.values.expand(step.get("name")))]
    attrs.append(("whiteboard", run.values.expand(step.get("whiteboard", "WB1"))))
    for key in ("type", "maxsize", "softsize", "hardsize", "softcount", "hardcount", "idle"):
        if step.has(key):
            attrs.append((key, run.values.expand(step.get(key))))
    msg = Message(
        type="Psyclone.System.Create.Stream",
        sender=run.kit.name,
        to="Psyclone",
        language="xml",
        content=serialize(element("stream", tuple(attrs))),
        content_is_xml=True,
    )
    _, reply = await run.kit.request(msg)
    if reply.type != "RECEIVE_ACCEPT":
        raise Inconclusive(f"the server refused to create the stream: {reply.content}")


def _payload(text: str) -> bytes:
    try:
        return base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as exc:
        raise ValueError(f"kit-stream-add: payload is not base64: {exc}") from exc


async def _add_samples(run: ScenarioRun, stream: str, payload: bytes, count: int) -> list[int]:
    assert run.kit is not None
    ids: list[int] = []
    for _ in range(count):
        msg = add_sample_request(stream, run.kit.name)
        chunk = encode_chunk(DataSample(payload=payload))
        _, reply = await run.kit.request(replace(msg, binary=(chunk,)))
        if reply.type != "DATA_ACCEPTED":
            raise Inconclusive(f"the stream refused the kit's sample: {reply.content}")
        ids.append(int(reply.content.strip()))
    return ids


async def _kit_stream_add(run: ScenarioRun, step: Step) -> None:
    """Add samples now, or `delay-ms` later in the background (for a waiting step)."""
    stream = run.values.expand(step.get("stream"))
    payload = _payload(run.values.expand(step.get("payload")))
    count = int(step.get("count", "1"))
    if not step.has("delay-ms"):
        ids = await _add_samples(run, stream, payload, count)
        run._check(step, {"sample_ids": ids})
        return

    async def later() -> None:
        await asyncio.sleep(int(step.get("delay-ms")) / 1000)
        await _add_samples(run, stream, payload, count)

    run.background.append(asyncio.create_task(later()))
    run._check(step, {"sample_ids": []})


def stream_steps(run: ScenarioRun) -> dict[str, Callable[[Step], Awaitable[None]]]:
    """The step handlers of this module, bound to `run`."""
    return {
        "call": lambda step: _call(run, step),
        "require": lambda step: _require(run, step),
        "kit-create-stream": lambda step: _create_stream(run, step),
        "kit-stream-add": lambda step: _kit_stream_add(run, step),
    }
