"""Secure mode (spec 14.3, extension `auth`): proofs, proved names, takeover and callbacks.

Not applicable on a server that does not advertise `auth`. The cases that prove a name need the
module secrets the server was given: `openair conform --auth-secrets FILE` (the same
`<secrets><module name secret/></secrets>` file); without them they are not applicable. Module
names come from that file, not from `ctx.name()`, so every case here is serial.
"""

from __future__ import annotations

import re

from openair.protocol.auth import proof
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair_conformance.cases._common import check_error, error_name, next_request, ping_ok
from openair_conformance.harness import CaseContext
from openair_conformance.harness.conn import ConnectionLost
from openair_conformance.harness.raw import RawConnection
from openair_conformance.model import Level, NotApplicable
from openair_conformance.registry import case

_NONCE_RE = re.compile(r"^[0-9a-f]{64}$")
_NEEDS = ("auth",)


def _secrets(ctx: CaseContext, count: int) -> list[tuple[str, str]]:
    """Return `count` (name, secret) pairs from --auth-secrets, or make the case N/A."""
    pairs = sorted(ctx.secrets.items())
    if len(pairs) < count:
        raise NotApplicable(
            f"needs {count} module secret(s) the server knows: run with --auth-secrets FILE"
        )
    return pairs[:count]


def _cns(type: str, name: str, content: str = "") -> Message:
    return Message(type=type, sender=name, to="CNS", content=content)


async def _nonce(ctx: CaseContext, raw: RawConnection, name: str) -> str:
    """Ask AUTH_CHALLENGE and return the nonce (Fail unless AUTH_NONCE, OA-AUTH-2)."""
    reply = await raw.request(_cns("AUTH_CHALLENGE", name))
    nonce = reply.content.strip()
    ctx.check(
        reply.type == "AUTH_NONCE" and bool(_NONCE_RE.match(nonce)),
        f"AUTH_CHALLENGE was answered {reply.type} {reply.content!r}",
        expected="AUTH_NONCE with 64 lowercase hex digits (OA-AUTH-2)",
    )
    return nonce


async def _prove(ctx: CaseContext, raw: RawConnection, name: str, secret: str) -> None:
    """Prove `name` on `raw` (Fail unless AUTH_ACCEPT, OA-AUTH-3)."""
    nonce = await _nonce(ctx, raw, name)
    reply = await raw.request(_cns("AUTH_RESPONSE", name, proof(secret, nonce, name)))
    ctx.check(
        reply.type == "AUTH_ACCEPT",
        f"the right proof for {name} was answered {reply.type} {reply.content!r}",
        expected="AUTH_ACCEPT (OA-AUTH-3)",
    )


async def _proved(ctx: CaseContext, label: str, name: str, secret: str) -> RawConnection:
    raw = await ctx.raw(label)
    await _prove(ctx, raw, name, secret)
    return raw


def _auth_required(ctx: CaseContext, reply: Message, what: str, *types: str) -> None:
    check_error(
        ctx,
        reply,
        types=types or ("RECEIVE_ERROR",),
        names=("AUTH_REQUIRED",),
        what=what,
        req="OA-AUTH-5",
    )


@case(
    id="AUTH-001",
    title="AUTH_CHALLENGE gives a fresh 64-hex-digit nonce each time, per connection",
    section="14.3",
    requirements=("OA-AUTH-2", "OA-AUTH-1", "OA-EXT-4"),
    needs=_NEEDS,
    serial=True,
    allowed=("AUTH_NONCE with 64 lowercase hex digits, never the same twice",),
)
async def auth_nonces(ctx: CaseContext) -> None:
    """Ask AUTH_CHALLENGE twice on one connection and once on another.

    Catches: no AUTH_CHALLENGE at a server that advertises `auth`, a short or upper-case
    nonce, and a nonce that repeats (a counter, a constant, one per server).
    """
    name = ctx.name("N")
    first, second = await ctx.raw("first"), await ctx.raw("second")
    nonces = [await _nonce(ctx, first, name), await _nonce(ctx, first, name)]
    nonces.append(await _nonce(ctx, second, name))
    ctx.check(
        len(set(nonces)) == 3,
        f"the nonces repeat: {nonces}",
        expected="a fresh random nonce for every AUTH_CHALLENGE (OA-AUTH-2)",
    )


@case(
    id="AUTH-002",
    title="A proof verifies only with the right secret, once, on the connection that asked",
    section="14.3",
    requirements=("OA-AUTH-3", "OA-AUTH-2"),
    needs=_NEEDS,
    serial=True,
    allowed=(
        "RECEIVE_ERROR 'AUTH_FAILED: …' without a pending challenge, for a wrong proof, for a "
        "proof of another connection's nonce and for a used nonce",
        "AUTH_ACCEPT for the right proof",
    ),
)
async def auth_proofs(ctx: CaseContext) -> None:
    """On one connection: AUTH_RESPONSE without a challenge; a proof made with a wrong secret
    (and then BIND_NOLISTEN); a proof of the nonce another connection got; the right proof; the
    same right proof again.

    Catches: a server that accepts any proof, ignores the secret, keeps a nonce after use, or
    shares nonces between connections.
    """
    ((name, secret),) = _secrets(ctx, 1)
    raw, other = await ctx.raw("prover"), await ctx.raw("other")

    def failed(reply: Message, what: str) -> None:
        check_error(ctx, reply, names=("AUTH_FAILED",), what=what, req="OA-AUTH-3")

    good = proof(secret, "0" * 64, name)
    failed(await raw.request(_cns("AUTH_RESPONSE", name, good)), "AUTH_RESPONSE unasked")
    nonce = await _nonce(ctx, raw, name)
    wrong = proof(secret + "x", nonce, name)
    failed(await raw.request(_cns("AUTH_RESPONSE", name, wrong)), "a proof with a wrong secret")
    bind = await raw.request(_cns("BIND_NOLISTEN", name))
    _auth_required(ctx, bind, "BIND_NOLISTEN after a failed proof", "BIND_ERROR")
    await _nonce(ctx, raw, name)  # pending here; the other connection asks next
    theirs = await _nonce(ctx, other, name)
    stolen = proof(secret, theirs, name)
    failed(await raw.request(_cns("AUTH_RESPONSE", name, stolen)), "another connection's nonce")
    nonce = await _nonce(ctx, raw, name)
    right = proof(secret, nonce, name)
    reply = await raw.request(_cns("AUTH_RESPONSE", name, right))
    ctx.check(
        reply.type == "AUTH_ACCEPT",
        f"the right proof was answered {reply.type} {reply.content!r}",
        expected="AUTH_ACCEPT (OA-AUTH-3)",
    )
    failed(await raw.request(_cns("AUTH_RESPONSE", name, right)), "a used nonce's proof")


@case(
    id="AUTH-003",
    title="A connection that proved no name can only ping, ask capabilities and prove",
    section="14.3",
    requirements=("OA-AUTH-5",),
    needs=_NEEDS,
    serial=True,
    allowed=(
        "BIND_ERROR, RECEIVE_ERROR or AIR.Retrieve.Failed with 'AUTH_REQUIRED: …'",
        "PING_SUCCESS and CAPABILITIES",
    ),
)
async def auth_unproved(ctx: CaseContext) -> None:
    """Without proving anything: BIND_NOLISTEN, a post, AIR.Subscribe, AIR.Retrieve, STATUS;
    then PING and GET_CAPABILITIES.

    Catches: a server that lets an anonymous connection bind, post, register or read.
    """
    name = ctx.name("U")
    raw = await ctx.raw()
    bind = await raw.request(_cns("BIND_NOLISTEN", name))
    _auth_required(ctx, bind, "BIND_NOLISTEN", "BIND_ERROR")
    post = Message(type=ctx.type("Anon"), sender=name, to="WB1", content="x")
    _auth_required(ctx, await raw.request(post), "a post")
    xml = f'<trigger from="WB1" type="{ctx.type("Anon")}"/>'
    subscribe = Message(
        type="AIR.Subscribe",
        sender=name,
        to="WB1",
        content=xml,
        content_is_xml=True,
        language="xml",
    )
    _auth_required(ctx, await raw.request(subscribe), "AIR.Subscribe")
    retrieve = Message(
        type="AIR.Retrieve",
        sender=name,
        to="WB1",
        content="<retrieve/>",
        content_is_xml=True,
        language="xml",
    )
    _auth_required(ctx, await raw.request(retrieve), "AIR.Retrieve", "AIR.Retrieve.Failed")
    _auth_required(ctx, await raw.request(_cns("STATUS", name)), "STATUS")
    await ping_ok(ctx, raw, what="after the refusals", req="OA-AUTH-5")
    caps = await raw.request(_cns("GET_CAPABILITIES", name))
    ctx.check(
        caps.type == "CAPABILITIES",
        f"GET_CAPABILITIES: {caps.type}",
        expected="CAPABILITIES before any proof (OA-AUTH-5)",
    )


@case(
    id="AUTH-004",
    title="A proved connection acts only for the name it proved",
    section="14.3",
    requirements=("OA-AUTH-5", "OA-AUTH-4"),
    needs=_NEEDS,
    serial=True,
    allowed=("RECEIVE_ACCEPT for its own post", "'AUTH_REQUIRED: …' for another from"),
)
async def auth_own_name(ctx: CaseContext) -> None:
    """Prove a name, post with it, then post, subscribe and ask CurrentPhase with another
    module's `from`; finally a fresh connection posts with the proved name.

    Catches: a server that checks that a connection proved something but not that `from` is
    what it proved, and a proof that carries over to another connection.
    """
    ((name, secret),) = _secrets(ctx, 1)
    raw = await _proved(ctx, "proved", name, secret)
    own = await raw.request(Message(type=ctx.type("Own"), sender=name, to="WB1"))
    ctx.check(
        own.type == "RECEIVE_ACCEPT",
        f"its own post: {own.type} {own.content!r}",
        expected="RECEIVE_ACCEPT (OA-AUTH-5)",
    )
    other = ctx.name("Other")
    forged = Message(type=ctx.type("Forged"), sender=other, to="WB1")
    _auth_required(ctx, await raw.request(forged), "a post with another from")
    xml = f'<trigger from="WB1" type="{ctx.type("Forged")}"/>'
    subscribe = Message(
        type="AIR.Subscribe",
        sender=other,
        to="WB1",
        content=xml,
        content_is_xml=True,
        language="xml",
    )
    _auth_required(ctx, await raw.request(subscribe), "AIR.Subscribe for another module")
    phase = Message(type="Psyclone.Module.Request.CurrentPhase", sender=other, to="Psyclone")
    _auth_required(ctx, await raw.request(phase), "CurrentPhase for another module")
    fresh = await ctx.raw("fresh")
    again = Message(type=ctx.type("Own"), sender=name, to="WB1")
    _auth_required(ctx, await fresh.request(again), "a post on a connection that proved nothing")


@case(
    id="AUTH-005",
    title="A bound name is taken over only by a connection that proved it",
    section="14.3",
    requirements=("OA-AUTH-7",),
    needs=_NEEDS,
    serial=True,
    allowed=(
        "BIND_ERROR 'AUTH_REQUIRED: …' from an unproved connection or one that proved another "
        "name, the owner's connection untouched",
        "BIND_ACCEPT from a connection that proved the name, and the old one closed",
    ),
)
async def auth_takeover(ctx: CaseContext) -> None:
    """Bind a proved name; BIND_NOLISTEN it from an unproved connection and (with a second
    secret) from one that proved another name; PING the owner; then prove the name on a new
    connection and bind it there.

    Catches: takeover by anyone (the core rule, OA-SESS-6, left on in secure mode), and a
    takeover check that only asks whether the connection proved some name.
    """
    pairs = _secrets(ctx, 1)
    name, secret = pairs[0]
    owner = await _proved(ctx, "owner", name, secret)
    bind = await owner.request(_cns("BIND_NOLISTEN", name))
    ctx.check(
        bind.type == "BIND_ACCEPT",
        f"the owner's BIND_NOLISTEN: {bind.type}",
        expected="BIND_ACCEPT after a proof (OA-AUTH-5)",
    )
    thief = await ctx.raw("thief")
    stolen = await thief.request(_cns("BIND_NOLISTEN", name))
    _auth_required(ctx, stolen, "BIND_NOLISTEN of a bound name, unproved", "BIND_ERROR")
    others = sorted(ctx.secrets.items())[1:]
    if others:
        other, other_secret = others[0]
        insider = await _proved(ctx, "insider", other, other_secret)
        taken = await insider.request(_cns("BIND_NOLISTEN", name))
        _auth_required(ctx, taken, f"BIND_NOLISTEN of {name} after proving {other}", "BIND_ERROR")
    await ping_ok(ctx, owner, what="on the owner's connection", req="OA-AUTH-7")
    heir = await _proved(ctx, "heir", name, secret)
    again = await heir.request(_cns("BIND_NOLISTEN", name))
    ctx.check(
        again.type == "BIND_ACCEPT",
        f"the proved takeover: {again.type} {again.content!r}",
        expected="BIND_ACCEPT from a connection that proved the name (OA-AUTH-7)",
    )
    await owner.expect_closed()


@case(
    id="AUTH-006",
    title="A Receive frame becomes a callback connection only after a proof of its from",
    section="14.3",
    requirements=("OA-AUTH-6",),
    needs=_NEEDS,
    serial=True,
    allowed=(
        "RECEIVE_ERROR 'AUTH_REQUIRED: …' and the connection closed for an unproved one",
        "no reply, and deliveries, on a proved one",
    ),
)
async def auth_callback(ctx: CaseContext) -> None:
    """Bind a proved name with BIND_NOLISTEN; send its RECEIVE_NAME_NOTIFICATION on an unproved
    connection; then on a connection that proved the name, and forward a message to the name.

    Catches: a server that lets anyone open a module's callback connection and so receive its
    deliveries (OA-SESS-7 replaces the older callback with the newer).
    """
    ((name, secret),) = _secrets(ctx, 1)
    primary = await _proved(ctx, "primary", name, secret)
    bind = await primary.request(_cns("BIND_NOLISTEN", name))
    ctx.check(
        bind.type == "BIND_ACCEPT",
        f"BIND_NOLISTEN: {bind.type}",
        expected="BIND_ACCEPT after a proof (OA-AUTH-5)",
    )
    note = Message(type="RECEIVE_NAME_NOTIFICATION", sender=name)
    thief = await ctx.raw("thief")
    await thief.send_message(note, FrameTag.RECEIVE)
    refused = await thief.read_message()
    check_error(
        ctx, refused, names=("AUTH_REQUIRED",), what="an unproved Receive frame", req="OA-AUTH-6"
    )
    await thief.expect_closed()
    callback = await _proved(ctx, "callback", name, secret)
    sent = await callback.send_message(note, FrameTag.RECEIVE)
    forward = Message(type=ctx.type("Fwd"), sender=name, to=name, content="to myself")
    ack = await primary.request(forward)
    ctx.check(
        ack.type == "RECEIVE_ACCEPT",
        f"forward to {name}: {ack.type}",
        expected="RECEIVE_ACCEPT (OA-SESS-22)",
    )
    got = await next_request(ctx, callback, receive_id=sent.id, name=name)
    ctx.check(
        got.type == forward.type,
        f"the callback received {got.type}",
        expected=f"the forwarded {forward.type} on the proved callback (OA-AUTH-6)",
    )
    await callback.send_message(got.reply("RECEIVE_ACCEPT", sender=name))


@case(
    id="AUTH-007",
    title="Wakeups and lifecycle notices are refused from modules",
    section="14.3",
    requirements=("OA-AUTH-8",),
    needs=_NEEDS,
    serial=True,
    allowed=(
        "RECEIVE_ERROR 'AUTH_REQUIRED: …' for AIR.Instruct.Wakeup and Psyclone.Module.Lost/"
        "Restored/Connect of another name, posted or forwarded",
        "RECEIVE_ACCEPT for Psyclone.Module.Connect.<own name>",
    ),
)
async def auth_server_types(ctx: CaseContext) -> None:
    """Prove and bind a name; post AIR.Instruct.Wakeup, Psyclone.Module.Lost.<other>,
    psyclone.module.restored.<name> and Psyclone.Module.Connect.<other> to AIRCentral, forward
    AIR.Instruct.Wakeup to itself; then post Psyclone.Module.Connect.<own name>.

    Catches: forged wakeups and forged Lost notices (which wake every module that watches
    `Psyclone.Module.Lost.*`), and a case-sensitive check.
    """
    ((name, secret),) = _secrets(ctx, 1)
    raw = await _proved(ctx, "module", name, secret)
    bind = await raw.request(_cns("BIND_NOLISTEN", name))
    ctx.check(
        bind.type == "BIND_ACCEPT",
        f"BIND_NOLISTEN: {bind.type}",
        expected="BIND_ACCEPT after a proof (OA-AUTH-5)",
    )
    other = ctx.name("Victim")
    for type_ in (
        "AIR.Instruct.Wakeup",
        f"Psyclone.Module.Lost.{other}",
        f"psyclone.module.restored.{name}",
        f"Psyclone.Module.Connect.{other}",
    ):
        reply = await raw.request(Message(type=type_, sender=name, to="AIRCentral"))
        check_error(
            ctx, reply, names=("AUTH_REQUIRED",), what=f"a post of {type_}", req="OA-AUTH-8"
        )
    forged = Message(type="AIR.Instruct.Wakeup", sender=name, to=name)
    check_error(
        ctx,
        await raw.request(forged),
        names=("AUTH_REQUIRED",),
        what="AIR.Instruct.Wakeup forwarded to a module",
        req="OA-AUTH-8",
    )
    own = await raw.request(
        Message(type=f"Psyclone.Module.Connect.{name}", sender=name, to="AIRCentral")
    )
    ctx.check(
        own.type == "RECEIVE_ACCEPT",
        f"Psyclone.Module.Connect.{name}: {own.type}",
        expected="RECEIVE_ACCEPT for its own Connect notice (OA-AUTH-8)",
    )


@case(
    id="AUTH-008",
    title="A server in secure mode serves no HTTP monitor on its main port",
    section="14.3",
    requirements=("OA-AUTH-11",),
    needs=_NEEDS,
    serial=True,
    allowed=("no `monitor` in CAPABILITIES; the connection closed without an HTTP answer",),
)
async def auth_no_monitor(ctx: CaseContext) -> None:
    """Check CAPABILITIES for `monitor`, then send `GET / HTTP/1.1` on the main port.

    Catches: the web monitor left on, which shows every whiteboard to anyone.
    """
    ctx.check(
        "monitor" not in ctx.server.capabilities,
        "the server advertises monitor",
        expected="no monitor in secure mode (OA-AUTH-11)",
    )
    raw = await ctx.raw("http")
    await raw.send(b"GET / HTTP/1.1\r\nHost: openair\r\n\r\n")

    async def answer() -> bytes:
        data = b""
        try:
            while chunk := await raw.stream.read_bytes():
                data += chunk
        except ConnectionLost:
            pass
        return data

    got = await ctx.wait(answer(), what="the answer to GET /", expected="the connection closed")
    ctx.check(
        not got.startswith(b"HTTP/"),
        f"the server answered HTTP: {got[:40]!r}",
        expected="no HTTP answer, the connection closed (OA-AUTH-11, OA-FRAME-6)",
    )


@case(
    id="AUTH-040",
    title="GET_CAPABILITIES and AUTH_CHALLENGE need no proof, to an empty to or to CNS",
    section="14.3",
    requirements=("OA-AUTH-5", "OA-AUTH-2", "OA-SESS-26"),
    allowed=("CAPABILITIES and AUTH_NONCE for each; never 'AUTH_REQUIRED: …'",),
)
async def auth_open_to_cns(ctx: CaseContext) -> None:
    """On a connection that proved nothing: GET_CAPABILITIES, then AUTH_CHALLENGE, each with an
    empty `to` and with `to` = CNS. Runs on every server: one that refuses GET_CAPABILITIES
    with AUTH_REQUIRED advertises nothing, not even `auth`.

    Catches: a gate that opens these commands only for one spelling of CNS (the kit would take
    the server for a legacy one and skip every secure-mode case).
    """
    raw = await ctx.raw()
    name = ctx.name("Open")
    for to in ("", "CNS"):
        caps = await raw.request(Message(type="GET_CAPABILITIES", sender=name, to=to))
        ctx.check(
            error_name(caps.content) != "AUTH_REQUIRED",
            f"GET_CAPABILITIES to {to!r} was refused: {caps.type} {caps.content!r}",
            expected="CAPABILITIES without a proof (OA-AUTH-5)",
        )
    if "auth" not in ctx.server.capabilities:
        raise NotApplicable("the server does not advertise auth")
    for to in ("", "CNS"):
        caps = await raw.request(Message(type="GET_CAPABILITIES", sender=name, to=to))
        ctx.check(
            caps.type == "CAPABILITIES",
            f"GET_CAPABILITIES to {to!r}: {caps.type} {caps.content!r}",
            expected="CAPABILITIES without a proof (OA-AUTH-5)",
        )
        nonce = await raw.request(Message(type="AUTH_CHALLENGE", sender=name, to=to))
        ctx.check(
            nonce.type == "AUTH_NONCE",
            f"AUTH_CHALLENGE to {to!r}: {nonce.type} {nonce.content!r}",
            expected="AUTH_NONCE without a proof (OA-AUTH-2, OA-AUTH-5)",
        )


@case(
    id="AUTH-041",
    title="Before a proof PING goes anywhere but to a bound module; the CNS commands only to CNS",
    section="14.3",
    requirements=("OA-AUTH-5", "OA-SESS-10", "OA-SESS-21"),
    needs=_NEEDS,
    allowed=(
        "RECEIVE_ERROR 'AUTH_REQUIRED: …' for GET_CAPABILITIES or AUTH_CHALLENGE to another "
        "component or a whiteboard",
        "PING_SUCCESS / KEEPALIVESUCCESS from WB1, FORWARD_FAILED for PING to an unbound name",
    ),
)
async def auth_open_only_to_cns(ctx: CaseContext) -> None:
    """On a connection that proved nothing: GET_CAPABILITIES to Psyclone and AIRServer,
    AUTH_CHALLENGE to WB1 and AIRCentral; then PING and KEEPALIVE to WB1 and PING to a name
    nobody bound.

    Catches: a gate that opens the CNS commands for other addressees (a whiteboard would store
    them as posts of an unproved name), and one that refuses PING to a whiteboard or to an
    unbound name, which OA-AUTH-5 leaves open.
    """
    raw = await ctx.raw()
    name = ctx.name("Anon")
    for kind, to in (
        ("GET_CAPABILITIES", "Psyclone"),
        ("GET_CAPABILITIES", "AIRServer"),
        ("AUTH_CHALLENGE", "WB1"),
        ("AUTH_CHALLENGE", "AIRCentral"),
    ):
        reply = await raw.request(Message(type=kind, sender=name, to=to))
        _auth_required(ctx, reply, f"{kind} to {to}")
    for kind, answer in (("PING", "PING_SUCCESS"), ("KEEPALIVE", "KEEPALIVESUCCESS")):
        reply = await raw.request(Message(type=kind, sender=name, to="WB1"))
        ctx.check(
            reply.type == answer,
            f"{kind} to WB1 was answered {reply.type} {reply.content!r}",
            expected=f"{answer} without a proof (OA-AUTH-5, OA-SESS-10)",
        )
    nobody = ctx.name("Nobody")
    reply = await raw.request(Message(type="PING", sender=name, to=nobody))
    ctx.check(
        reply.type == "FORWARD_FAILED",
        f"PING to the unbound {nobody} was answered {reply.type} {reply.content!r}",
        expected="FORWARD_FAILED: PING to an unbound name needs no proof (OA-AUTH-5, OA-SESS-21)",
    )


@case(
    id="AUTH-042",
    title="An AUTH_REQUIRED refusal of a post comes from the whiteboard addressed",
    section="14.3",
    requirements=("OA-SESS-32", "OA-AUTH-5"),
    level=Level.SHOULD,
    needs=_NEEDS,
    allowed=("RECEIVE_ERROR 'AUTH_REQUIRED: …' from WB1, then from AIRCentral",),
)
async def auth_refusal_sender(ctx: CaseContext) -> None:
    """Post to WB1 and to AIRCentral on a connection that proved nothing.

    Catches: refusals always sent from CNS, whichever whiteboard was addressed.
    """
    raw = await ctx.raw()
    name = ctx.name("Anon")
    for board in ("WB1", "AIRCentral"):
        reply = await raw.request(Message(type=ctx.type("Anon"), sender=name, to=board))
        _auth_required(ctx, reply, f"a post to {board}")
        ctx.check(
            reply.sender == board,
            f"the refusal of a post to {board} came from {reply.sender!r}",
            expected=f"from = {board}, the answering whiteboard (OA-SESS-32)",
        )
