"""Capability and extension cases (spec 15, and the default limits of 14.1): CAPABILITIES,
declaring an unknown extension, `gettime` and the `monitor` extension's HTTP endpoint.
"""

from __future__ import annotations

from openair.protocol.message import Message
from openair_conformance.cases._common import (
    cns_request,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    attributes,
    content_object,
    content_root,
)
from openair_conformance.harness.probe import parse_capabilities_xml
from openair_conformance.model import Level, NotApplicable
from openair_conformance.registry import case

_EXTENSIONS = frozenset(
    {"noreply", "pipelining", "usec", "gettime", "durable", "typed-streams", "contexts", "monitor"}
    | {"qos"}
)


_LIMITS = {
    "max-frame-xml": 16_777_216,
    "max-frame-binary": 67_108_864,
    "max-xml-depth": 64,
    "max-in-flight": 256,
    "max-queue": 10_000,
    "max-triggers": 1024,
    "max-type-bytes": 255,
    "max-type-segments": 32,
    "frame-deadline-ms": 30_000,
}


# -- 14.1 Limits -------------------------------------------------------------------------------


@case(
    id="CAP-002",
    title="The advertised limits are the spec's defaults (a configured server may differ)",
    section="14.1",
    requirements=("OA-LIM-1", "OA-LIM-2", "OA-LIM-3", "OA-LIM-5", "OA-LIM-6"),
    level=Level.INFO,
    allowed=("any value when the server was configured; the table of 14.1 otherwise",),
)
async def default_limits(ctx: CaseContext) -> None:
    """Compare the advertised limits with the defaults of 14.1 (informational).

    Catches: a server whose defaults differ from the spec (only meaningful when the server
    runs unconfigured).
    """
    if ctx.server.legacy or not ctx.server.limits:
        raise NotApplicable("the server advertises no limits")
    differ = {n: v for n, v in ctx.server.limits if n in _LIMITS and _LIMITS[n] != v}
    ctx.check(not differ, f"limits that differ from the defaults: {differ}", expected=str(_LIMITS))


# -- 15.1 CAPABILITIES -------------------------------------------------------------------------


@case(
    id="CAP-001",
    title="CAPABILITIES names the protocol, known extensions only (never auth) and every limit",
    section="15.1",
    requirements=(
        "OA-SESS-23",
        "OA-CAP-1",
        "OA-CAP-3",
        "OA-LIM-4",
        "OA-EXT-1",
        "OA-EXT-4",
        "OA-SESS-20",
    ),
    allowed=(
        "CAPABILITIES with <capabilities protocol='OpenAIR/1.0' server='…'>, one <extension> per "
        "implemented extension, one <limit> per limit of 14.1",
        "UNKNOWN_COMMAND 'Offending cmd: GET_CAPABILITIES' (a legacy server)",
    ),
)
async def capabilities(ctx: CaseContext) -> None:
    """Ask GET_CAPABILITIES and check the content against section 15.1 and 14.1.

    Catches: a missing limit, a limit that is not a non-negative integer, an invented or
    reserved extension name (`auth`), a wrong protocol string, duplicate entries.
    """
    reply = await (await ctx.raw()).request(cns_request(ctx, "GET_CAPABILITIES"))
    if reply.type == "UNKNOWN_COMMAND":
        ctx.check(
            reply.content.strip() == "Offending cmd: GET_CAPABILITIES",
            f"content {reply.content!r}",
            expected="OA-SESS-20",
        )
        ctx.vacuous("a legacy server: nothing advertised to check")
        return
    ctx.check(
        reply.type == "CAPABILITIES", f"GET_CAPABILITIES: {reply.type}", expected="OA-SESS-23"
    )
    try:
        protocol, server, extensions, limits = parse_capabilities_xml(reply.content)
    except ValueError as exc:
        ctx.fail(str(exc), expected="<capabilities> (OA-CAP-1)")
    ctx.check(
        protocol == "OpenAIR/1.0" and bool(server),
        f"protocol={protocol!r} server={server!r}",
        expected="OA-CAP-1",
    )
    unknown = [e for e in extensions if e not in _EXTENSIONS]
    ctx.check(
        not unknown,
        f"unknown or reserved extensions advertised: {unknown}",
        expected="OA-EXT-1, OA-EXT-4",
    )
    ctx.check(
        len(set(extensions)) == len(extensions), f"duplicates in {extensions}", expected="OA-CAP-1"
    )
    names = [name for name, _ in limits]
    missing = [n for n in _LIMITS if n not in names]
    ctx.check(
        not missing, f"limits not advertised: {missing}", expected="every limit of 14.1 (OA-LIM-4)"
    )
    ctx.check(
        all(v >= 0 for _, v in limits),
        f"limits {limits}",
        expected="non-negative decimal integers (OA-CAP-1)",
    )
    written = [
        attributes(child).get("value", "")
        for child in content_object(reply, "capabilities")
        if isinstance(child.tag, str) and child.tag.lower() == "limit"
    ]
    ctx.check(
        all(value.isascii() and value.isdigit() for value in written),
        f"limit values as written: {written}",
        expected="ASCII digits only: no sign, unit, fraction or exponent (OA-CAP-1)",
    )


# -- 15.2 Extensions ---------------------------------------------------------------------------


@case(
    id="SESS-014",
    title="A module that declares an unknown extension name is bound as usual",
    section="15.2",
    requirements=("OA-EXT-1", "OA-SESS-19"),
    allowed=("BIND_ACCEPT; the unknown name is ignored",),
)
async def unknown_extension_declared(ctx: CaseContext) -> None:
    """BIND with `<extensions>x-conformance-unknown</extensions>`.

    Catches: a server that refuses a BIND because of an extension name it does not know.
    """
    raw = await ctx.raw()
    bind = Message(type="BIND_NOLISTEN", sender=ctx.name("X"), to="CNS")
    reply = await raw.request(bind.with_extra("extensions", "x-conformance-unknown"))
    ctx.check(
        reply.type == "BIND_ACCEPT" and reply.content.strip() == "-1",
        f"BIND_NOLISTEN declaring an unknown extension was answered {reply.type} {reply.content!r}",
        expected="BIND_ACCEPT with -1: unknown names are ignored (OA-EXT-1)",
    )


@case(
    id="EXT-001",
    title="GET_TIME is answered TIME with one <time sec msec/> element, without usec",
    section="15.2",
    requirements=("OA-EXT-2", "OA-GEN-2"),
    needs=("gettime",),
    allowed=(
        "TIME whose content is one time element; no usec for a requester that did not declare it",
    ),
)
async def get_time(ctx: CaseContext) -> None:
    """Ask GET_TIME twice on a connection that declared nothing; times must not go backwards.

    Catches: a TIME reply without a time element, a `usec` sent to a peer that did not declare
    it, and a clock read once at start-up.
    """
    raw = await ctx.raw()
    stamps = []
    for _ in range(2):
        reply = await raw.request(cns_request(ctx, "GET_TIME"))
        ctx.check(reply.type == "TIME", f"GET_TIME: {reply.type}", expected="TIME (OA-EXT-2)")
        roots = content_root(reply)  # OA-EXT-2: one <time sec msec/>, from the server's clock
        ctx.check(len(roots) == 1, f"TIME holds {len(roots)} elements", expected="one time element")
        attrs = attributes(roots[0])
        ctx.check("usec" not in attrs, f"TIME has usec: {attrs}", expected="no usec (OA-GEN-2)")
        ctx.check(
            attrs.get("sec", "").lstrip("-").isdigit(),
            f"TIME attributes {attrs}",
            expected="a sec attribute",
        )
        stamps.append(int(attrs["sec"]) * 1000 + int(attrs.get("msec", "0") or 0))
    ctx.check(
        stamps[0] <= stamps[1],
        f"the second TIME {stamps[1]} precedes the first {stamps[0]}",
        expected="a clock",
    )


@case(
    id="EXT-002",
    title="A monitor server answers HTTP on its main port",
    section="15.2",
    requirements=("OA-EXT-3",),
    needs=("monitor",),
    allowed=("an HTTP/1.x status line in answer to GET /",),
)
async def monitor_http(ctx: CaseContext) -> None:
    """Send `GET / HTTP/1.1` on a fresh connection to the main port.

    Catches: a server that advertises monitor but closes the connection as an unknown tag.
    """
    raw = await ctx.raw()
    await raw.send(b"GET / HTTP/1.1\r\nHost: conformance\r\nConnection: close\r\n\r\n")
    data = await ctx.wait(raw.stream.read_bytes(), what="HTTP answer")
    ctx.check(data.startswith(b"HTTP/1."), f"the answer starts {data[:40]!r}", expected="OA-EXT-3")
