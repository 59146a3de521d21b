"""A stateful test of routing: modules bind, subscribe, post, retrieve and leave over TCP.

Hypothesis drives three or four modules against one reference server and compares every answer
with an in-memory model written from the spec alone: who is woken (triggers OA-TRIG-1..4, cc
OA-CC-1..4), exactly once (OA-WAKE-5) and with which `lasttrigger` (OA-WAKE-4, OA-WAKE-6), what a
retrieve returns (OA-RET-3..6) and what eviction leaves (OA-WB-6), and the Lost notice of a
module that leaves (OA-SESS-15). Each example uses fresh names and a fresh type prefix, so the
examples share the server without seeing each other's messages.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterator
from dataclasses import dataclass, field, replace

import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    invariant,
    precondition,
    rule,
    run_state_machine_as_test,
)
from wire_helpers import (
    WAIT,
    Delivery,
    LegacyModule,
    RawConn,
    ServerThread,
    collection_messages,
    now,
)

from openair.protocol.message import Message
from openair.server.core.config import WhiteboardConfig, default_config

SMALL_MAX = 3
BOARDS = ("WB1", "WB2", "Small")
TYPES = ("A", "B", "A.B", "B.A", "A.A", "C")
PATTERNS = ("A", "B", "A.B", "A.*", "*", "*.B", "A*", "*B*", "B.*", "a.b")
TRIG_FROM = ("WB1", "wb2", "Small", "any", "*", "", None)
LATEST = (None, 0, 1, 2, 5)
TRIGGERS = st.lists(
    st.tuples(st.sampled_from((*PATTERNS, "LOST")), st.sampled_from(TRIG_FROM)),
    min_size=1,
    max_size=3,
)
_COUNTER = itertools.count()


def glob_matches(pattern: str, type_: str) -> bool:
    """The spec matcher, written again from 5.2 (OA-MATCH-1..6)."""
    p, t = pattern.lower(), type_.lower()
    regex = ".*".join(re.escape(part) for part in p.split("*"))
    return re.fullmatch(regex, t) is not None or (p.endswith(".*") and t == p[:-2])


def from_matches(trigger_from: str | None, board: str) -> bool:
    """OA-TRIG-2: case-insensitive; any, *, empty and absent mean every whiteboard."""
    if trigger_from in (None, "", "any", "*"):
        return True
    return trigger_from.lower() == board.lower()


@dataclass(frozen=True)
class Trig:
    pattern: str
    board: str | None


@dataclass
class ModelModule:
    name: str
    bound: bool = False
    triggers: tuple[Trig, ...] = ()
    self_ok: bool = False


@dataclass
class Model:
    """The spec's routing, for one example."""

    modules: dict[str, ModelModule] = field(default_factory=dict)
    boards: dict[str, list[tuple[str, str, str]]] = field(default_factory=dict)  # id, type, from

    def wakeups(self, sender: str, board: str, type_: str, cc: str) -> dict[str, str]:
        """Return module -> lasttrigger for a stored post (8.4-8.6)."""
        named = {n.strip() for n in cc.split(";") if n.strip()}  # OA-CC-1
        woken: dict[str, str] = {}
        for mod in self.modules.values():
            if not mod.bound:
                continue
            may_trigger = mod.name != sender or mod.self_ok  # OA-TRIG-4
            fired = [
                t.pattern
                for t in mod.triggers
                if may_trigger and from_matches(t.board, board) and glob_matches(t.pattern, type_)
            ]
            if fired:
                woken[mod.name] = fired[0]  # OA-WAKE-6: all `after` are 0, first wins
            elif mod.name in named:
                woken[mod.name] = ""  # OA-CC-2, OA-CC-4
        return woken

    def store(self, board: str, msg_id: str, type_: str, sender: str) -> None:
        self.boards.setdefault(board, []).append((msg_id, type_, sender))

    def retrieve(
        self, board: str, pattern: str, sender: str | None, latest: int | None
    ) -> list[str]:
        kept = self.boards.get(board, [])
        if board == "Small":
            kept = kept[-SMALL_MAX:]  # OA-WB-6: our posts are the newest on Small
        hits = [i for i, t, s in reversed(kept) if glob_matches(pattern, t) and sender in (None, s)]
        limit = 1 if latest is None else latest  # OA-RET-4
        return hits if limit == 0 else hits[:limit]


@dataclass
class Live:
    """The sockets of one bound module."""

    module: LegacyModule
    primary: RawConn
    mode: str
    pending: list[Delivery] = field(default_factory=list)


class Server:
    """The one server all examples share."""

    thread: ServerThread | None = None


def server_port() -> int:
    assert Server.thread is not None
    return Server.thread.port


class RoutingMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.prefix = f"Rm{next(_COUNTER)}"
        self.names = [f"{self.prefix}m{i}" for i in range(4)]
        self.model = Model(modules={n: ModelModule(n) for n in self.names})
        self.live: dict[str, Live] = {}
        self.poster = RawConn(server_port())
        self.seen_ids: set[tuple[str, str]] = set()
        self.lost_ids: set[str] = set()

    def typ(self, suffix: str) -> str:
        return f"{self.prefix}.{suffix}"

    # --- rules ------------------------------------------------------------------------------

    @initialize(
        modes=st.lists(st.sampled_from(("callback", "listen")), min_size=3, max_size=4),
        data=st.data(),
    )
    def bind_some(self, modes: list[str], data: st.DataObject) -> None:
        """Start with three or four bound, registered modules, so that most rules route."""
        for i, mode in enumerate(modes):
            self.bind(i, mode)
            self.subscribe(i, data)

    @rule(i=st.integers(0, 3), mode=st.sampled_from(("callback", "listen")))
    def bind(self, i: int, mode: str) -> None:
        name = self.names[i]
        if name in self.live:
            return
        module = LegacyModule(name, server_port())
        primary = RawConn(server_port())
        if mode == "listen":
            port = module.listen(0)
            bind = Message(
                type="BIND",
                sender=name,
                to="CNS",
                posted=now(),
                content_is_xml=True,
                language="xml",
                content=f'<tcplocation port="{port}"/>',
            )
        else:
            bind = Message(type="BIND_NOLISTEN", sender=name, to="CNS", posted=now())
        reply = primary.request(bind)
        assert reply.type == "BIND_ACCEPT", (reply.type, reply.content)  # OA-SESS-3/4/5
        assert reply.content == (str(port) if mode == "listen" else "-1"), reply.content
        live = Live(module=module, primary=primary, mode=mode)
        if mode == "callback":
            module.open_callback()
            self.barrier(live)
        self.live[name] = live
        self.model.modules[name] = ModelModule(name, bound=True)

    def barrier(self, live: Live) -> None:
        """Wait until the server uses the new callback connection.

        The `Receive` frame gets no reply (OA-SESS-7), so a post that names only this module in
        `cc` and matches no trigger of the example is the one way to know it was processed.
        """
        sync = Message(
            type=f"Zz.Sync.{self.prefix}",
            sender="Checker",
            to="AIRCentral",
            cc=live.module.name,
            posted=now(),
        )
        assert self.poster.request(sync).type == "RECEIVE_ACCEPT"
        delivery = self.take_wakeup(live, sync.id)
        assert delivery.path == "callback", delivery.path  # the only path of BIND_NOLISTEN

    @rule(i=st.integers(0, 3), data=st.data())
    def subscribe(self, i: int, data: st.DataObject) -> None:
        trigs = data.draw(TRIGGERS, label="triggers")
        self_ok = data.draw(st.booleans(), label="allowselftriggering")
        form = data.draw(st.sampled_from(("bare", "module")), label="form")
        name = self.names[i]
        if name not in self.live:
            return
        triggers = tuple(
            Trig(f"Psyclone.Module.Lost.{self.prefix}m*", "AIRCentral")
            if p == "LOST"
            else Trig(self.typ(p), b)
            for p, b in trigs
        )
        if form == "bare":
            self_ok = False  # allowselftriggering lives on <module> (OA-REG-6)
        xml = registration_xml(name, triggers, self_ok, form)
        msg = Message(
            type="AIR.Subscribe",
            sender=name,
            to="AIRCentral",
            posted=now(),
            content=xml,
            content_is_xml=True,
            language="xml",
        )
        reply = self.live[name].primary.request(msg)
        assert reply.type == "RECEIVE_ACCEPT", (reply.type, reply.content, xml)  # OA-REG-7
        self.model.modules[name] = replace(
            self.model.modules[name], triggers=triggers, self_ok=self_ok
        )

    @rule(
        poster=st.integers(-1, 3),
        board=st.sampled_from(BOARDS),
        suffix=st.sampled_from(TYPES),
        cc=st.lists(st.sampled_from(("m0", "m1", "m2", "m3", "nobody", "poster")), max_size=2),
        sep=st.sampled_from((";", " ; ")),
    )
    def post(self, poster: int, board: str, suffix: str, cc: list[str], sep: str) -> None:
        sender = self.names[poster] if poster >= 0 else f"{self.prefix}poster"
        ccs = sep.join(sender if c == "poster" else f"{self.prefix}{c}" for c in cc)
        msg = Message(
            type=self.typ(suffix), sender=sender, to=board, cc=ccs, posted=now(), content=suffix
        )
        conn = self.live[sender].primary if sender in self.live else self.poster
        reply = conn.request(msg)
        assert reply.type == "RECEIVE_ACCEPT", (reply.type, reply.content)  # OA-WB-3, OA-CC-3
        self.model.store(board, msg.id, msg.type, sender)
        self.expect_wakeups(msg.id, self.model.wakeups(sender, board, msg.type, ccs))

    @rule(
        pattern=st.sampled_from((*PATTERNS, "*", "*")),
        sender=st.sampled_from((None, None, None, 0, 1, -1)),
        latest=st.sampled_from(LATEST),
        as_attr=st.booleans(),
        data=st.data(),
    )
    def retrieve(
        self,
        pattern: str,
        sender: int | None,
        latest: int | None,
        as_attr: bool,
        data: st.DataObject,
    ) -> None:
        board = data.draw(st.sampled_from(sorted(self.model.boards) or BOARDS), label="board")
        who = (
            None
            if sender is None
            else (self.names[sender] if sender >= 0 else f"{self.prefix}poster")
        )
        attrs = f' from="{board}" type="{self.typ(pattern)}"' + (f' sender="{who}"' if who else "")
        body = ""
        if latest is not None:
            attrs, body = (
                (attrs + f' latest="{latest}"', "")
                if as_attr
                else (attrs, f"<latest>{latest}</latest>")
            )
        spec = f"<retrieve{attrs}>{body}</retrieve>"
        msg = Message(
            type="AIR.Retrieve",
            sender="Checker",
            to="AIRCentral",
            posted=now(),
            content=spec,
            content_is_xml=True,
            language="xml",
        )
        reply = self.poster.request(msg)
        assert reply.type == "AIR.Retrieve.Success", (reply.type, reply.content)
        got = [m.id for m in collection_messages(reply)]
        want = self.model.retrieve(board, self.typ(pattern), who, latest)
        assert got == want, (spec, got, want)  # OA-RET-3..6, OA-WB-6

    @precondition(lambda self: bool(self.live))
    @rule(data=st.data())
    def disconnect(self, data: st.DataObject) -> None:
        name = data.draw(st.sampled_from(sorted(self.live)))
        live = self.live.pop(name)
        lost_type = f"Psyclone.Module.Lost.{name}"
        live.primary.close()
        if live.mode == "callback":
            assert live.module.callback_closed.wait(WAIT), "callback not closed (OA-SESS-15)"
        lost = self.wait_for_lost(lost_type)
        self.check_quiet(live)
        live.module.close()
        self.model.modules[name] = ModelModule(name)  # registration removed (OA-SESS-15)
        self.model.store("AIRCentral", lost.id, lost_type, "Psyclone")
        self.expect_wakeups(lost.id, self.model.wakeups("Psyclone", "AIRCentral", lost_type, ""))

    # --- checks -----------------------------------------------------------------------------

    def wait_for_lost(self, lost_type: str) -> Message:
        """Retrieve (bounded, one request at a time) until the Lost notice is stored."""
        spec = f'<retrieve from="AIRCentral" type="{lost_type}"><latest>0</latest></retrieve>'
        for _ in range(2000):
            msg = Message(
                type="AIR.Retrieve",
                sender="Checker",
                to="AIRCentral",
                posted=now(),
                content=spec,
                content_is_xml=True,
                language="xml",
            )
            found = collection_messages(self.poster.request(msg))
            if found and found[0].id not in self.lost_ids:
                assert found[0].sender == "Psyclone", found[0]  # OA-SESS-15
                assert len(found) == len(self.lost_ids & {m.id for m in found}) + 1, found
                self.lost_ids.add(found[0].id)
                return found[0]
        raise AssertionError(f"{lost_type} never posted to AIRCentral (OA-SESS-15)")

    def expect_wakeups(self, msg_id: str, want: dict[str, str]) -> None:
        """Wait (bounded) for each expected wakeup and check it; no module may get two."""
        for name, lasttrigger in want.items():
            live = self.live[name]
            delivery = self.take_wakeup(live, msg_id)
            assert delivery.lasttrigger == lasttrigger, (name, delivery.lasttrigger, lasttrigger)
        for live in self.live.values():
            self.check_quiet(live)

    def take_wakeup(self, live: Live, msg_id: str) -> Delivery:
        while True:
            for d in live.pending:
                if d.trigger is not None and d.trigger.id == msg_id:
                    live.pending.remove(d)
                    return d
            try:
                self.note(live, live.module.take())
            except TimeoutError:
                raise AssertionError(f"{live.module.name} not woken by {msg_id}") from None

    def note(self, live: Live, delivery: Delivery) -> None:
        if not delivery.is_wakeup:
            return  # PING, KEEPALIVE, phase updates (OA-WAKE-9)
        assert delivery.trigger is not None
        key = (live.module.name, delivery.trigger.id)
        assert key not in self.seen_ids, f"woken twice by one message: {key} (OA-WAKE-5)"
        self.seen_ids.add(key)
        live.pending.append(delivery)

    def check_quiet(self, live: Live) -> None:
        """Every wakeup that has arrived was expected (and taken)."""
        for delivery in live.module.drain():
            self.note(live, delivery)
        extra = [(d.trigger.type, d.lasttrigger) for d in live.pending if d.trigger is not None]
        assert not extra, f"{live.module.name}: unexpected wakeups {extra}"
        assert not live.module.errors, live.module.errors

    @invariant()
    def modules_healthy(self) -> None:
        for live in self.live.values():
            assert not live.module.errors, live.module.errors

    def teardown(self) -> None:
        try:
            for name, live in self.live.items():
                fence = Message(
                    type=f"Zz.Fence.{self.prefix}",
                    sender="Checker",
                    to="WB1",
                    cc=name,
                    posted=now(),
                    priority=6.999,
                )
                assert self.poster.request(fence).type == "RECEIVE_ACCEPT"
                self.take_wakeup(live, fence.id)
                self.check_quiet(live)
        finally:
            for live in self.live.values():
                live.primary.close()
                live.module.close()
            self.poster.close()


def registration_xml(name: str, triggers: tuple[Trig, ...], self_ok: bool, form: str) -> str:
    """Write a registration in the bare form (OA-REG-2) or the module form (OA-REG-3)."""
    items = "".join(
        f'<trigger type="{t.pattern}"' + ("" if t.board is None else f' from="{t.board}"') + "/>"
        for t in triggers
    )
    if form == "bare":
        return f"<triggers>{items}</triggers>"
    flag = ' allowselftriggering="yes"' if self_ok else ""
    return f'<module name="{name}"{flag}><triggers>{items}</triggers></module>'


@pytest.fixture(scope="module", autouse=True)
def shared_server() -> Iterator[None]:
    config = default_config()
    small = WhiteboardConfig(name="Small", maxcount=SMALL_MAX)
    config = replace(config, whiteboards=(*config.whiteboards, small))
    Server.thread = ServerThread(config=config)
    yield
    Server.thread.stop()
    Server.thread = None


def test_routing_machine() -> None:
    base = settings()
    run_state_machine_as_test(
        RoutingMachine,
        settings=settings(base, max_examples=min(30, base.max_examples), stateful_step_count=15),
    )


@pytest.mark.fuzz
def test_routing_machine_long() -> None:
    run_state_machine_as_test(RoutingMachine, settings=settings(stateful_step_count=40))
