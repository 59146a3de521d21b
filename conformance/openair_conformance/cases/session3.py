"""Session cases, continued (spec 6.1, 6.2, 6.4, 6.7, 6.8, 6.10 and 15): RESOLVE, PING,
KEEPALIVE and STATUS, configuration queries, capabilities and the reply envelope.

The first session cases are in session.py; IDs continue from SESS-009. Cases that need a module
whose callback connection the suite reads itself use `_common.raw_module`.
"""

from __future__ import annotations

from openair.message import Message
from openair_conformance.cases._common import (
    esc,
    setup_subscribe,
    triggers_xml,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    attributes,
    content_object,
    content_root,
)
from openair_conformance.harness.probe import parse_capabilities_xml
from openair_conformance.model import Level, NotApplicable
from openair_conformance.registry import case

_COMPONENTS = ("CNS", "Config", "Psyclone", "AIRServer", "ContextsAndPhases")
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


def _msg(
    ctx: CaseContext, type: str, to: str = "CNS", content: str = "", sfx: str = "S"
) -> Message:
    return Message(type=type, sender=ctx.name(sfx), to=to, content=content)


# -- 6.4 RESOLVE, 6.2 addressing --------------------------------------------------------------


@case(
    id="SESS-015",
    title="RESOLVE_REQUEST resolves whiteboards and system components, case-sensitively",
    section="6.4",
    requirements=("OA-SESS-8", "OA-WB-1", "OA-WB-10", "OA-CONF-4"),
    allowed=(
        "RESOLVE_SUCCESS with <tcplocation address port name/> for AIRCentral, WB1, WB2 and "
        "the system components",
        "RESOLVE_FAILED for wb1 and aircentral",
    ),
)
async def resolve_components(ctx: CaseContext) -> None:
    """Resolve AIRCentral, WB1, WB2, CNS, Config, Psyclone, AIRServer, ContextsAndPhases, then
    `wb1` and `aircentral`.

    Catches: a missing default whiteboard or component, a tcplocation that names another
    component, and case-insensitive name lookup.
    """
    raw = await ctx.raw()
    for name in ("AIRCentral", "WB1", "WB2", *_COMPONENTS):
        reply = await raw.request(_msg(ctx, "RESOLVE_REQUEST", content=name))
        ctx.check(
            reply.type == "RESOLVE_SUCCESS",
            f"RESOLVE of {name}: {reply.type}",
            expected="RESOLVE_SUCCESS (OA-SESS-8, OA-WB-1)",
        )
        try:
            location = attributes(content_object(reply, "tcplocation"))
        except WakeupUnreadable as exc:
            ctx.fail(f"RESOLVE of {name}: {exc}", expected="<tcplocation address port name/>")
        ctx.check(
            location.get("name") == name and location.get("port", "").isdigit(),
            f"RESOLVE of {name} gave {location}",
            expected=f"name='{name}' and a port (OA-SESS-8)",
        )
    for name in ("wb1", "aircentral"):
        reply = await raw.request(_msg(ctx, "RESOLVE_REQUEST", content=name))
        ctx.check(
            reply.type == "RESOLVE_FAILED",
            f"RESOLVE of {name} was answered {reply.type}",
            expected="RESOLVE_FAILED: names are case-sensitive (OA-SESS-8, OA-WB-10)",
        )


@case(
    id="SESS-016",
    title="PING is answered PING_SUCCESS by CNS, by an empty to, by whiteboards and components",
    section="6.7",
    requirements=("OA-SESS-10", "OA-SESS-26", "OA-SESS-1"),
    allowed=("PING_SUCCESS with isresponse = the PING's id, for every addressee",),
)
async def ping_everyone(ctx: CaseContext) -> None:
    """PING `""`, CNS, AIRCentral, WB1, WB2 and every system component on one connection.

    Catches: a component that does not answer PING, or answers it RECEIVE_ACCEPT (a Psyclone
    module that does so never gets wakeups), and an empty `to` not taken as CNS.
    """
    raw = await ctx.raw()
    for to in ("", "AIRCentral", "WB1", "WB2", *_COMPONENTS):
        sent = await raw.send_message(_msg(ctx, "PING", to=to))
        reply = await raw.read_message()
        ctx.check(
            reply.type == "PING_SUCCESS" and reply.isresponse == sent.id,
            f"PING to {to!r} was answered {reply.type} (isresponse {reply.isresponse!r})",
            expected="PING_SUCCESS for the PING (OA-SESS-10, OA-SESS-1)",
        )


@case(
    id="SESS-017",
    title="KEEPALIVESUCCESS carries the KEEPALIVE's id in isresponse",
    section="6.7",
    requirements=("OA-SESS-1", "OA-KEEP-2"),
    allowed=("KEEPALIVESUCCESS with isresponse = the KEEPALIVE's id",),
)
async def keepalive_isresponse(ctx: CaseContext) -> None:
    """Send KEEPALIVE with empty from and to; check the reply's isresponse.

    Catches: Psyclone's KEEPALIVESUCCESS with an empty isresponse (DEV-24).
    """
    raw = await ctx.raw()
    sent = await raw.send_message(Message(type="KEEPALIVE"))
    reply = await raw.read_message()
    ctx.check(
        reply.type == "KEEPALIVESUCCESS" and reply.isresponse == sent.id,
        f"KEEPALIVE was answered {reply.type} with isresponse {reply.isresponse!r}",
        expected="KEEPALIVESUCCESS with isresponse = the request's id (OA-SESS-1)",
    )


@case(
    id="SESS-018",
    title="An empty to addresses CNS on the main port (BIND_NOLISTEN, RESOLVE, STATUS)",
    section="6.2",
    requirements=("OA-SESS-26",),
    allowed=("the CNS replies: BIND_ACCEPT -1, RESOLVE_SUCCESS, STATUS_SUCCESS",),
)
async def empty_to_is_cns(ctx: CaseContext) -> None:
    """Send CNS commands with `to` empty.

    Catches: a server that routes an empty `to` to nowhere (FORWARD_FAILED) instead of CNS.
    """
    raw = await ctx.raw()
    wants = (
        ("BIND_NOLISTEN", "", "BIND_ACCEPT"),
        ("RESOLVE_REQUEST", "WB1", "RESOLVE_SUCCESS"),
        ("STATUS", "", "STATUS_SUCCESS"),
    )
    for type_, content, want in wants:
        reply = await raw.request(_msg(ctx, type_, to="", content=content))
        ctx.check(reply.type == want, f"{type_} with to='' got {reply.type}", expected="OA-SESS-26")


@case(
    id="SESS-019",
    title="STATUS is answered STATUS_SUCCESS with a dictionary holding Name and Created",
    section="6.7",
    requirements=("OA-SESS-25",),
    allowed=("STATUS_SUCCESS whose <dictionary> has the entries Name and Created (and others)",),
)
async def status(ctx: CaseContext) -> None:
    """Send STATUS to CNS and read the dictionary.

    Catches: a STATUS reply without the entries a monitor relies on.
    """
    reply = await (await ctx.raw()).request(_msg(ctx, "STATUS"))
    ctx.check(reply.type == "STATUS_SUCCESS", f"STATUS: {reply.type}", expected="OA-SESS-25")
    entries = _dictionary(ctx, reply)
    ctx.check(
        entries.get("Name") == "CNS" and bool(entries.get("Created")),
        f"STATUS entries: {sorted(entries)} (Name={entries.get('Name')!r})",
        expected="Name='CNS' and a non-empty Created (OA-SESS-25)",
    )


def _dictionary(ctx: CaseContext, reply: Message) -> dict[str, str]:
    try:
        dictionary = content_object(reply, "dictionary")
    except WakeupUnreadable as exc:
        ctx.fail(f"{reply.type} content: {exc}", expected="a <dictionary>")
    return {
        attributes(e).get("name", ""): "".join(str(t) for t in e.itertext())
        for e in dictionary
        if isinstance(e.tag, str) and e.tag.lower() == "entry"
    }


# -- 6.8 configuration queries ----------------------------------------------------------------


@case(
    id="SESS-020",
    title="GET_ENTRY Global gives the global dictionary; an unknown module gives no content",
    section="6.8",
    requirements=("OA-SESS-12",),
    allowed=(
        "ENTRY with a <dictionary> holding spec, name, title, description, datastorefile, htmldir",
        "ENTRY with empty content for a module the configuration does not have",
    ),
)
async def get_entry(ctx: CaseContext) -> None:
    """Ask Config for `Global` and for a module name nobody configured.

    Catches: missing global entries (a JavaOpenAIR module reads them right after binding) and
    an ENTRY for an unconfigured module that carries a made-up `<module>`.
    """
    raw = await ctx.raw()
    reply = await raw.request(_msg(ctx, "GET_ENTRY", to="Config", content="Global"))
    ctx.check(reply.type == "ENTRY", f"GET_ENTRY Global: {reply.type}", expected="ENTRY")
    missing = {"spec", "name", "title", "description", "datastorefile", "htmldir"}
    missing -= set(_dictionary(ctx, reply))
    ctx.check(not missing, f"the global entry lacks {sorted(missing)}", expected="OA-SESS-12")
    reply = await raw.request(_msg(ctx, "GET_ENTRY", to="Config", content=ctx.name("Nobody")))
    ctx.check(
        reply.type == "ENTRY" and not reply.content.strip(),
        f"GET_ENTRY of an unconfigured module: {reply.type} {reply.content[:200]!r}",
        expected="ENTRY with no content (OA-SESS-12)",
    )


@case(
    id="SESS-021",
    title="CurrentPhase answers no content before a registration and the <phase> after it",
    section="6.8",
    requirements=("OA-SESS-13",),
    allowed=(
        "Psyclone.Module.CurrentPhase with empty content for an unregistered module",
        "then a <phase> whose triggers include the registered pattern",
    ),
)
async def current_phase(ctx: CaseContext) -> None:
    """Ask Psyclone for the phase of a bound module, register a trigger, ask again.

    Catches: a CurrentPhase that ignores the module's registration, or that invents a phase
    for a module without one.
    """
    module = await ctx.module("M")
    ask = Message(type="Psyclone.Module.Request.CurrentPhase", sender=module.name, to="Psyclone")
    before = await module.request(ask)
    ctx.check(
        before.type == "Psyclone.Module.CurrentPhase" and not before.content.strip(),
        f"before registering: {before.type} {before.content[:200]!r}",
        expected="Psyclone.Module.CurrentPhase with no content (OA-SESS-13)",
    )
    pattern = ctx.type("Go.*")
    await setup_subscribe(module, triggers_xml(pattern))
    after = await module.request(Message(type=ask.type, sender=module.name, to="Psyclone"))
    try:
        phase = content_object(after, "phase")
    except WakeupUnreadable as exc:
        ctx.fail(f"after registering: {exc}", expected="a <phase> (OA-SESS-13)")
    types = [attributes(t).get("type") for t in phase.iter() if str(t.tag).lower() == "trigger"]
    ctx.check(pattern in types, f"the phase's triggers are {types}", expected="OA-SESS-13")


@case(
    id="SESS-022",
    title="GET_ID, GET_NAME and System.PerfStat to AIRServer are answered",
    section="6.8",
    requirements=("OA-SESS-14",),
    allowed=("ID (the same non-empty text twice), NAME (non-empty), RECEIVE_ACCEPT",),
)
async def airserver(ctx: CaseContext) -> None:
    """Ask GET_ID on two connections, GET_NAME, and send a System.PerfStat.

    Catches: an id that changes between requests, an empty NAME, a PerfStat left unanswered.
    """
    ids = []
    for _ in range(2):
        reply = await (await ctx.raw()).request(_msg(ctx, "GET_ID", to="AIRServer"))
        ctx.check(
            reply.type == "ID" and bool(reply.content.strip()),
            f"GET_ID: {reply.type} {reply.content!r}",
            expected="ID with text (OA-SESS-14)",
        )
        ids.append(reply.content.strip())
    ctx.check(ids[0] == ids[1], f"GET_ID answered {ids}", expected="the same id (OA-SESS-14)")
    raw = await ctx.raw()
    reply = await raw.request(_msg(ctx, "GET_NAME", to="AIRServer"))
    ctx.check(
        reply.type == "NAME" and bool(reply.content.strip()),
        f"GET_NAME: {reply.type} {reply.content!r}",
        expected="NAME (OA-SESS-14)",
    )
    perf = Message(
        type="System.PerfStat",
        sender=ctx.name("S"),
        to="AIRServer",
        content_is_xml=True,
        language="xml",
        content=f'<perfstat name="{ctx.name("S")}" count="0" received="0" posted="0"/>',
    )
    reply = await raw.request(perf)
    ctx.check(
        reply.type == "RECEIVE_ACCEPT", f"System.PerfStat: {reply.type}", expected="OA-SESS-14"
    )


@case(
    id="SESS-023",
    title="Components other than CNS answer an unknown command UNKNOWN_COMMAND",
    section="6.2",
    requirements=("OA-SESS-29",),
    level=Level.SHOULD,
    allowed=("UNKNOWN_COMMAND with content 'Offending cmd: <type>' from each component",),
)
async def unknown_command_components(ctx: CaseContext) -> None:
    """Send an unknown command type to Config, Psyclone, AIRServer and ContextsAndPhases.

    Catches: a component that forwards, ignores or acknowledges a command it does not know.
    """
    raw = await ctx.raw()
    command = f"CONF_NO_SUCH_COMMAND_{ctx.run_id}".upper()
    for to in _COMPONENTS[1:]:
        reply = await raw.request(_msg(ctx, command, to=to))
        ctx.check(
            reply.type == "UNKNOWN_COMMAND"
            and reply.content.strip() == f"Offending cmd: {command}",
            f"{command} to {to} was answered {reply.type} {reply.content!r}",
            expected="UNKNOWN_COMMAND 'Offending cmd: <type>' (OA-SESS-29)",
        )


# -- 6.10 and 15 capabilities ------------------------------------------------------------------


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
    reply = await (await ctx.raw()).request(_msg(ctx, "GET_CAPABILITIES"))
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
        reply = await raw.request(_msg(ctx, "GET_TIME"))
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


# -- 6.1 requests and replies ------------------------------------------------------------------


@case(
    id="SESS-028",
    title="Every kind of request gets exactly one reply whose isresponse is its id",
    section="6.1",
    requirements=("OA-SESS-1", "OA-SESS-18", "OA-MSG-11"),
    allowed=("one reply per request, in order, each with isresponse = the request's id",),
)
async def isresponse_everywhere(ctx: CaseContext) -> None:
    """Send, one at a time on one connection, a post, a refused post, AIR.Subscribe, a retrieve,
    RESOLVE, STATUS, GET_ENTRY, GET_ID, an unknown command and a message to nowhere.

    Catches: replies without isresponse (they cannot be paired), and a server that answers a
    lone request only once more data arrives.
    """
    raw = await ctx.raw()
    me = ctx.name("Q")
    requests = [
        Message(type=ctx.type("Post"), sender=me, to="WB1", content="x"),
        Message(type=ctx.type("Bad..Type"), sender=me, to="WB1"),
        Message(
            type="AIR.Subscribe",
            sender=me,
            to="AIRCentral",
            content="<triggers/>",
            content_is_xml=True,
            language="xml",
        ),
        Message(
            type="AIR.Retrieve",
            sender=me,
            to="AIRCentral",
            content=f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"/>',
            content_is_xml=True,
            language="xml",
        ),
        Message(type="RESOLVE_REQUEST", sender=me, to="CNS", content="WB1"),
        Message(type="STATUS", sender=me, to="CNS"),
        Message(type="GET_ENTRY", sender=me, to="Config", content="Global"),
        Message(type="GET_ID", sender=me, to="AIRServer"),
        Message(type=f"CONF_NOPE_{ctx.run_id}".upper(), sender=me, to="CNS"),
        Message(type=ctx.type("Lost"), sender=me, to=ctx.name("Nobody")),
    ]
    for request in requests:
        sent = await raw.send_message(request)
        reply = await raw.read_message()
        ctx.check(
            reply.isresponse == sent.id,
            f"{sent.type} was answered {reply.type} with isresponse {reply.isresponse!r}",
            expected="isresponse = the request's id (OA-SESS-1)",
        )


@case(
    id="SESS-029",
    title="Replies carry a fresh id, the answering component in from and the requester in to",
    section="6.1",
    requirements=("OA-SESS-32", "OA-MSG-8"),
    level=Level.SHOULD,
    allowed=(
        "distinct non-empty ids; from = CNS, WB1 or AIRCentral as addressed; to = the "
        "requester; a postedTime",
    ),
)
async def reply_envelope(ctx: CaseContext) -> None:
    """PING CNS, post to WB1, retrieve via AIRCentral; check each reply's envelope.

    Catches: replies that reuse the request's id, come from a generic name, or lack a time.
    """
    raw = await ctx.raw()
    me = ctx.name("E")
    requests = [
        (Message(type="PING", sender=me, to="CNS"), "CNS"),
        (Message(type=ctx.type("Post"), sender=me, to="WB1", content="x"), "WB1"),
        (
            Message(
                type="AIR.Retrieve",
                sender=me,
                to="AIRCentral",
                content=f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"/>',
                content_is_xml=True,
                language="xml",
            ),
            "AIRCentral",
        ),
    ]
    ids = set()
    for request, component in requests:
        sent = await raw.send_message(request)
        reply = await raw.read_message()
        ctx.check(
            bool(reply.id) and reply.id != sent.id and reply.id not in ids,
            f"{reply.type} has id {reply.id!r}",
            expected="a fresh id (OA-SESS-32, OA-MSG-8)",
        )
        ids.add(reply.id)
        got = (reply.sender, reply.to, reply.posted is not None)
        ctx.check(
            got == (component, me, True),
            f"{reply.type} from/to/postedTime: {got}",
            expected=f"({component!r}, {me!r}, True) (OA-SESS-32)",
        )
