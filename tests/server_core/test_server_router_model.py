"""A stateful test of the Router against a small, independent model of the routing rules.

The model keeps bound modules, registrations and whiteboard contents as plain lists and applies
the rules of spec sections 7–9 directly (OA-TRIG-1..4, OA-CC-1..4, OA-WAKE-5..7, OA-RET-3..6,
OA-WB-6, OA-SESS-6, OA-SESS-15), using only `matching.matches` from the implementation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule
from router_harness import MS, Harness

from openair.protocol.framing import FrameTag
from openair.protocol.matching import matches
from openair.protocol.message import Message
from openair.protocol.objects import parse_message_collection
from openair.protocol.wakeup import parse_wakeup
from openair.server.core.config import parse_config
from openair.server.core.router import Outcome

SPEC = (
    b'<psySpec name="Model" version="1.2"><whiteboard name="AIRCentral" maxcount="6"/>'
    b'<whiteboard name="WB1" maxcount="5"/><whiteboard name="WB2"/></psySpec>'
)
MODULES = ["M1", "M2", "M3"]
BOARDS = ["AIRCentral", "WB1", "WB2"]
TYPES = ["A", "A.B", "A.B.C", "A.X.C", "B", "B.C", "C"]
PATTERNS = ["*", "A.*", "A.B", "A.*.C", "*.C", "B*", "A.B.*", "Psyclone.Module.*", "c"]
TRIGGER_FROM = [None, "WB1", "wb1", "WB2", "any", "AIRCentral"]
SENDERS = [*MODULES, "Poster"]

triggers = st.lists(
    st.tuples(st.sampled_from(PATTERNS), st.sampled_from(TRIGGER_FROM), st.sampled_from([0, 5, 9])),
    max_size=4,
)
retrieve = st.none() | st.tuples(
    st.sampled_from(PATTERNS), st.sampled_from([None, "WB1", "WB2"]), st.integers(0, 3)
)


@dataclass
class ModelReg:
    triggers: list[tuple[str, str | None, int]]
    allow_self: bool
    retrieve: tuple[str, str | None, int] | None


@dataclass
class Stored:
    type: str
    sender: str
    wbid: int


@dataclass
class Model:
    bound: dict[str, int] = field(default_factory=dict)  # name -> primary conn
    callbacks: dict[str, int] = field(default_factory=dict)  # name -> callback conn (OA-SESS-7)
    regs: dict[str, ModelReg] = field(default_factory=dict)
    boards: dict[str, list[Stored]] = field(default_factory=lambda: {b: [] for b in BOARDS})
    next_wbid: dict[str, int] = field(default_factory=lambda: dict.fromkeys(BOARDS, 1))
    maxcount: dict[str, int] = field(
        default_factory=lambda: {"AIRCentral": 6, "WB1": 5, "WB2": 10_000}
    )

    def store(self, board: str, type_: str, sender: str) -> Stored:
        item = Stored(type=type_, sender=sender, wbid=self.next_wbid[board])
        self.next_wbid[board] += 1
        self.boards[board].append(item)
        del self.boards[board][: -self.maxcount[board]]  # OA-WB-6
        return item

    def select(self, board: str, pattern: str, latest: int) -> list[Stored]:
        hits = [m for m in reversed(self.boards[board]) if matches(pattern, m.type)]  # OA-RET-6
        return hits if latest == 0 else hits[:latest]  # OA-RET-4

    def woken(
        self, board: str, item: Stored, cc: list[str]
    ) -> dict[str, tuple[int, str, list[int]]]:
        """Return module -> (after, lasttrigger, retrieved wbids) for one stored message."""
        result: dict[str, tuple[int, str, list[int]]] = {}
        for name in self.bound:
            reg = self.regs.get(name)
            best: tuple[int, str] | None = None
            for pattern, source, after in reg.triggers if reg else []:
                if source not in (None, "any") and source.lower() != board.lower():
                    continue  # OA-TRIG-2
                if item.sender == name and not reg.allow_self:  # type: ignore[union-attr]
                    continue  # OA-TRIG-4
                if matches(pattern, item.type) and (best is None or after < best[0]):
                    best = (after, pattern)  # OA-WAKE-6
            if best is None and name in cc:
                best = (0, "")  # OA-CC-2, OA-CC-4
            if best is None:
                continue
            retrieved: list[int] = []
            if reg is not None and reg.retrieve is not None:
                pattern, source, latest = reg.retrieve
                retrieved = [m.wbid for m in self.select(source or board, pattern, latest)]
            result[name] = (best[0], best[1], retrieved)
        return result


def _registration_xml(reg: ModelReg) -> str:
    parts = []
    for pattern, source, after in reg.triggers:
        attr = "" if source is None else f' from="{source}"'
        parts.append(f'<trigger{attr} type="{pattern}" after="{after}"/>')
    retrieves = ""
    if reg.retrieve is not None:
        pattern, source, latest = reg.retrieve
        attr = "" if source is None else f' from="{source}"'
        one = f'<retrieve{attr} type="{pattern}"><latest>{latest}</latest></retrieve>'
        retrieves = f"<retrieves>{one}</retrieves>"
    flag = ' allowselftriggering="yes"' if reg.allow_self else ""
    return f'<module name="x"{flag}><triggers>{"".join(parts)}</triggers>{retrieves}</module>'


class RouterMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.h = Harness(parse_config(SPEC, source="model.xml"))
        self.model = Model()
        self.model.store("AIRCentral", "Psyclone.Context:Psyclone.System.Ready", "Psyclone")
        self.next_conn = 100

    def _conn(self) -> int:
        self.next_conn += 1
        return self.next_conn

    def _check(self, outcome: Outcome, board: str, item: Stored, cc: list[str], now: int) -> None:
        """Compare the wakeups of one stored message with the model's."""
        expected = self.model.woken(board, item, cc)
        got: dict[str, tuple[int, str, list[int]]] = {}
        for delivery in outcome.deliveries:
            wakeup = parse_wakeup(delivery.message)
            if (
                wakeup.trigger is None
                or wakeup.trigger.stored != board
                or wakeup.trigger.wbid != item.wbid
            ):
                continue
            assert delivery.module not in got  # OA-WAKE-5
            retrieved = [m.wbid or 0 for m in wakeup.retrieved]
            got[delivery.module] = ((delivery.due_ns - now) // MS, wakeup.lasttrigger, retrieved)
            assert wakeup.trigger.type == item.type and wakeup.trigger.sender == item.sender
        assert got == expected

    def _notice(self, outcome: Outcome, type_: str) -> None:
        item = self.model.store("AIRCentral", type_, "Psyclone")
        self._check(outcome, "AIRCentral", item, [], self.h.now)

    @rule(name=st.sampled_from(MODULES))
    def bind(self, name: str) -> None:
        conn = self._conn()
        outcome = self.h.bind(conn, name)
        if name in self.model.bound:  # OA-SESS-6: takeover
            old = [self.model.bound[name]]
            if name in self.model.callbacks:
                old.append(self.model.callbacks.pop(name))
            assert sorted(outcome.close_conns) == sorted(old)
            self._notice(outcome, f"Psyclone.Module.Restored.{name}")
            for conn_id in old:
                closed = self.h.close(conn_id)
                assert closed.deliveries == () and closed.discard_queues == ()
        else:
            assert outcome.deliveries == () and outcome.close_conns == ()
        self.model.bound[name] = conn
        info = self.h.router.module(name)
        assert info is not None and info.callback == self.model.callbacks.get(name)

    @rule(name=st.sampled_from(MODULES), trig=triggers, allow_self=st.booleans(), ret=retrieve)
    def subscribe(
        self,
        name: str,
        trig: list[tuple[str, str | None, int]],
        allow_self: bool,
        ret: tuple[str, str | None, int] | None,
    ) -> None:
        reg = ModelReg(triggers=trig, allow_self=allow_self, retrieve=ret)
        conn = self.model.bound.get(name, 7)
        outcome = self.h.subscribe(conn, name, _registration_xml(reg), to="WB2")
        assert [r.type for r in outcome.replies] == ["RECEIVE_ACCEPT"]
        phase_updates = [d.module for d in outcome.deliveries]
        assert phase_updates == ([name] if name in self.model.bound else [])  # OA-WAKE-9
        self.model.regs[name] = reg

    @rule(
        board=st.sampled_from(BOARDS),
        type_=st.sampled_from(TYPES),
        sender=st.sampled_from(SENDERS),
        cc=st.lists(st.sampled_from([*MODULES, "Nobody", "m1"]), max_size=2),
    )
    def post(self, board: str, type_: str, sender: str, cc: list[str]) -> None:
        outcome = self.h.post(3, type_, to=board, sender=sender, cc=";".join(cc))
        assert [r.type for r in outcome.replies] == ["RECEIVE_ACCEPT"]
        item = self.model.store(board, type_, sender)
        self._check(outcome, board, item, cc, self.h.now)
        assert len(outcome.deliveries) == len(self.model.woken(board, item, cc))

    @rule(name=st.sampled_from(MODULES))
    def disconnect(self, name: str) -> None:
        conn = self.model.bound.pop(name, None)
        if conn is None:
            return
        outcome = self.h.close(conn)
        assert outcome.discard_queues == (name,)  # OA-SESS-15
        callback = self.model.callbacks.pop(name, None)
        assert outcome.close_conns == (() if callback is None else (callback,))
        self.model.regs.pop(name, None)
        self._notice(outcome, f"Psyclone.Module.Lost.{name}")

    @rule(
        board=st.sampled_from(BOARDS), pattern=st.sampled_from(PATTERNS), latest=st.integers(0, 4)
    )
    def retrieve(self, board: str, pattern: str, latest: int) -> None:
        xml = f'<retrieve from="{board}" type="{pattern}"><latest>{latest}</latest></retrieve>'
        answer = self.h.reply(
            1, "AIR.Retrieve", to="WB1", sender="R", content=xml, content_is_xml=True
        )
        got = [(m.type, m.wbid) for m in parse_message_collection(answer.content)]
        assert got == [(m.type, m.wbid) for m in self.model.select(board, pattern, latest)]

    @rule(name=st.sampled_from(MODULES))
    def callback(self, name: str) -> None:
        rnn = Message(type="RECEIVE_NAME_NOTIFICATION", sender=name)
        conn = self._conn()
        outcome = self.h.send(conn, rnn, tag=FrameTag.RECEIVE)
        assert outcome.replies == ()  # OA-SESS-7
        older = self.model.callbacks.get(name)
        assert outcome.close_conns == (() if older is None else (older,))
        if older is not None:
            assert self.h.close(older) == Outcome()
        self.model.callbacks[name] = conn

    @invariant()
    def bound_modules_agree(self) -> None:
        for name in MODULES:
            info = self.h.router.module(name)
            assert (info is not None) == (name in self.model.bound)
            if info is not None:
                assert info.conn == self.model.bound[name]


RouterMachine.TestCase.settings = settings(settings(), stateful_step_count=40)
TestRouterModel = RouterMachine.TestCase
