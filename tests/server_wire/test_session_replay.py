"""Replay the session vectors (spec/vectors/sessions) against the reference server over raw sockets.

Each vector file is one session: the frames legacy clients sent (copied from the Psyclone wire
transcripts) and the answers the spec requires. A fresh server (port 0) serves each session.
Modules answer deliveries as JavaOpenAIR does. At the end every module still reachable gets a fence
post that names it in `cc`; once each fence wakeup has arrived, any wakeup that no step expected is
a failure (a module woken twice, or woken by a message that should not wake it, OA-WAKE-5).
"""

from __future__ import annotations

import contextlib
import json
import re
from pathlib import Path
from typing import Any

import pytest
from wire_helpers import (
    WAIT,
    Delivery,
    LegacyModule,
    RawConn,
    ServerThread,
    attr,
    children,
    collection_messages,
    content_elements,
    now,
)

from openair.protocol.codec import decode_message
from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.protocol.xmlsafe import local_name

VECTORS = Path(__file__).resolve().parents[2] / "spec" / "vectors" / "sessions"
FORMAT = "openair-session-vectors/1"
FILES = sorted(VECTORS.glob("*.json"))
_REF = re.compile(r"^\$(id|msg)-of-step-(\d+)$")


def load(path: Path) -> dict[str, Any]:
    """Read one vector file and check its format tag."""
    data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    assert data["format"] == FORMAT, path
    return data


class Replay:
    """Runs one session: connections by name, modules by name, and what was sent at each step."""

    def __init__(self, port: int, name: str) -> None:
        self.port = port
        self.name = name
        self.conns: dict[str, RawConn] = {}
        self.modules: dict[str, LegacyModule] = {}
        self.callbacks: dict[str, LegacyModule] = {}
        self.sent: dict[int, Message | None] = {}
        self.ids: dict[int, str] = {}  # the id of each sent frame, also when it does not decode
        self.primary: dict[str, str] = {}  # module -> the connection its BIND_ACCEPT came on
        self.closed: set[str] = set()
        self.bound_by: dict[str, str] = {}  # conn -> the name its last BIND request carried
        self.seen: dict[str, list[Delivery]] = {}
        self.used: set[int] = set()  # ids of deliveries an expect_wakeup step consumed

    def where(self, n: int, step: dict[str, Any]) -> str:
        return f"{self.name} step {n} {step.get('requirements', '')} {step.get('origin', '')}"

    def conn(self, name: str) -> RawConn:
        if name not in self.conns:
            self.conns[name] = RawConn(self.port)
        return self.conns[name]

    def module(self, name: str) -> LegacyModule:
        if name not in self.modules:
            self.modules[name] = LegacyModule(name, self.port)
            self.seen[name] = []
        return self.modules[name]

    def ref(self, value: str) -> str:
        match = _REF.match(value)
        return self.ids[int(match.group(2))] if match else value

    def sent_msg(self, value: str) -> Message:
        match = _REF.match(value)
        assert match, value
        msg = self.sent[int(match.group(2))]
        assert msg is not None, value
        return msg

    # --- steps -----------------------------------------------------------------------------

    def run(self, steps: list[dict[str, Any]]) -> None:
        for n, step in enumerate(steps, start=1):
            where = self.where(n, step)
            if "send" in step:
                self.do_send(n, step)
            elif "send_raw_hex" in step:
                self.conn(step["conn"]).send_raw(bytes.fromhex(step["send_raw_hex"]))
            elif "expect" in step:
                self.do_expect(step["conn"], step["expect"], where)
            elif "expect_closed" in step:
                self.do_expect_closed(step["conn"], where)
            elif "close" in step:
                self.conns[step["conn"]].close()
                self.closed.add(step["conn"])
            elif "expect_wakeup" in step:
                self.do_wakeup(step["module"], step["expect_wakeup"], where)
            else:
                raise AssertionError(f"unknown step kind: {step}")

    def do_send(self, n: int, step: dict[str, Any]) -> None:
        xml = step["send"]["xml"].encode("utf-8")
        tag = FrameTag(step["send"]["tag"])
        try:
            msg: Message | None = decode_message(xml)
        except Exception:
            msg = None  # deliberately broken XML: the step tests the error reply
        self.sent[n] = msg
        found = re.search(r"<id>([^<]*)</id>", step["send"]["xml"])
        self.ids[n] = msg.id if msg is not None else (found.group(1) if found else "")
        name = step["conn"]
        if tag is FrameTag.RECEIVE and msg is not None:
            conn = RawConn(self.port)
            self.conns[name] = conn
            conn.send_xml(xml, tag)
            module = self.module(msg.sender)
            module.adopt_callback(conn)
            self.callbacks[name] = module
            return
        if msg is not None and msg.type in ("BIND", "BIND_NOLISTEN"):
            self.bound_by[name] = msg.sender
        self.conn(name).send_xml(xml, tag)

    def do_expect(self, name: str, want: dict[str, Any], where: str) -> None:
        try:
            reply = self.conn(name).recv()
        except TimeoutError:
            raise AssertionError(f"{where}: no reply within {WAIT} s") from None
        check_reply(reply, want, self.ref, where)
        if reply.type == "BIND_ACCEPT" and name in self.bound_by:
            self.after_bind(self.bound_by.pop(name), reply.content, name)

    def after_bind(self, name: str, port_text: str, conn: str) -> None:
        """Listen on the port BIND_ACCEPT names, as a conformant module must (OA-DELIV-10)."""
        module = self.module(name)
        self.primary[name] = conn
        port = int(port_text)
        if port > 0 and module.listen_port != port:
            # A port taken on this host: deliveries must then use the callback connection.
            with contextlib.suppress(OSError):
                module.listen(port)

    def do_expect_closed(self, name: str, where: str) -> None:
        self.closed.add(name)
        if name in self.callbacks:
            module = self.callbacks[name]
            assert module.callback_closed.wait(WAIT), f"{where}: callback connection not closed"
            return
        try:
            frames = self.conns[name].frames_until_eof()
        except TimeoutError:
            raise AssertionError(f"{where}: the server did not close the connection") from None
        assert not frames, f"{where}: frames before the close: {[f.xml[:80] for f in frames]}"

    def collect(self, module: str) -> None:
        for delivery in self.module(module).drain():
            self.seen[module].append(delivery)

    def find(self, module: str, trigger_id: str, where: str) -> Delivery:
        """Wait (bounded) for the wakeup of `module` whose trigger message has `trigger_id`."""
        mod = self.module(module)
        while True:
            self.collect(module)
            for delivery in self.seen[module]:
                if id(delivery) in self.used or not delivery.is_wakeup:
                    continue
                assert delivery.trigger is not None
                if delivery.trigger.id == trigger_id:
                    self.used.add(id(delivery))
                    return delivery
            try:
                self.seen[module].append(mod.take())
            except TimeoutError:
                got = [d.trigger.type for d in self.seen[module] if d.trigger is not None]
                raise AssertionError(f"{where}: {module} not woken; wakeups seen: {got}") from None

    def do_wakeup(self, module: str, want: dict[str, Any], where: str) -> None:
        sent = self.sent_msg(want["trigger"])
        delivery = self.find(module, sent.id, where)
        check_wakeup(delivery, sent, want, where)

    # --- the end: fences, then nothing unexpected -------------------------------------------

    def finish(self) -> None:
        fence_conn = RawConn(self.port)
        fences: dict[str, str] = {}
        for name, module in self.modules.items():
            bound = self.primary.get(name) not in (None, *self.closed)
            reachable = module.listener is not None or (
                module.callback is not None and not module.callback_closed.is_set()
            )
            if not (bound and reachable):
                continue
            msg = Message(
                type="Zz.Fence",
                sender="FenceClient",
                to="WB1",
                cc=name,
                posted=now(),
                priority=6.999,
                content=f"fence for {name}",
            )
            reply = fence_conn.request(msg)
            assert reply.type == "RECEIVE_ACCEPT", (reply.type, reply.content)
            fences[name] = msg.id
        for name, fence_id in fences.items():
            self.find(name, fence_id, f"{self.name} end fence")
        fence_conn.close()
        for name in self.modules:
            self.collect(name)
            extra = [
                (d.trigger.type, d.trigger.id, d.lasttrigger)
                for d in self.seen[name]
                if d.is_wakeup and id(d) not in self.used and d.trigger is not None
            ]
            assert not extra, f"{self.name}: {name} got wakeups no step expected: {extra}"
            assert not self.modules[name].errors, self.modules[name].errors

    def close(self) -> None:
        for conn in self.conns.values():
            conn.close()
        for module in self.modules.values():
            module.close()


def check_reply(reply: Message, want: dict[str, Any], ref: Any, where: str) -> None:
    """Check one reply against the step's expectation (OA-SESS-1, OA-SESS-2 and the content)."""
    got = f"{where}: got {reply.type} isresponse={reply.isresponse!r} content={reply.content!r}"
    if "type" in want:
        assert reply.type == want["type"], got
    if "type_in" in want:
        assert reply.type in want["type_in"], got
    if "isresponse" in want:
        # OA-SESS-1/OA-SESS-2: the reply answers this request, in request order.
        assert reply.isresponse == ref(want["isresponse"]), got
    for key, field in (("from", "sender"), ("to", "to")):
        if key in want:
            assert getattr(reply, field) == want[key], f"{got} {key}={getattr(reply, field)!r}"
    if "content_regex" in want:
        assert re.fullmatch(want["content_regex"], reply.content, re.DOTALL), got
    if "content_root" in want:
        roots = content_elements(reply)
        assert roots and local_name(roots[0]) == want["content_root"], got
    if "dict_entries" in want:
        roots = content_elements(reply)
        assert roots and local_name(roots[0]) == "dictionary", got
        names = {attr(e, "name") for e in children(roots[0], "entry")}
        assert set(want["dict_entries"]) <= names, f"{got} entries={names}"
    if "results" in want:
        check_results(collection_messages(reply), want["results"], got)


def check_results(results: list[Message], want: list[list[str | None]], where: str) -> None:
    """Compare retrieve results with (type, content) pairs, in order (OA-RET-6, OA-RET-7)."""
    seen = [(m.type, m.content) for m in results]
    assert [m.type for m in results] == [w[0] for w in want], f"{where} results={seen}"
    for msg, (_, content) in zip(results, want, strict=True):
        if content is not None:
            assert msg.content == content, f"{where} results={seen}"
        assert msg.stored and msg.wbid is not None and msg.received is not None, (
            f"{where}: stored copy lacks stored/wbid/receivedTime (OA-WB-4): {msg!r}"
        )
    wbids = [m.wbid for m in results if m.stored == (results[0].stored if results else "")]
    assert wbids == sorted(wbids, key=lambda w: -(w or 0)), f"{where}: not newest first {wbids}"


def check_wakeup(delivery: Delivery, sent: Message, want: dict[str, Any], where: str) -> None:
    """Check a wakeup against OA-WAKE-1..4 and the stored copy against the post (OA-WB-4)."""
    msg, trigger = delivery.message, delivery.trigger
    assert trigger is not None
    wb = want.get("from")
    if wb is not None:
        assert msg.sender == wb and msg.stored == wb, f"{where}: wakeup from={msg.sender!r}"
        assert trigger.stored == wb, f"{where}: stored={trigger.stored!r}"
    assert msg.to == delivery.module, f"{where}: wakeup to={msg.to!r} (OA-WAKE-1)"
    if "type" in want:
        assert trigger.type == want["type"], where
    for field in ("type", "id", "sender", "to", "cc", "content", "posted"):
        assert getattr(trigger, field) == getattr(sent, field), (
            f"{where}: stored copy changed {field}: {getattr(trigger, field)!r} "
            "(OA-WB-4, OA-TIME-4)"
        )
    assert trigger.received is not None and trigger.wbid is not None, f"{where}: OA-WB-4"
    if "lasttrigger" in want:
        assert delivery.has_phase, f"{where}: wakeup without PhaseSpec (OA-WAKE-4)"
        assert delivery.lasttrigger == want["lasttrigger"], (
            f"{where}: lasttrigger={delivery.lasttrigger!r} (OA-WAKE-4, OA-WAKE-6)"
        )
    if "retrieved" in want:
        got = [m.type for m in delivery.retrieved]
        assert got == want["retrieved"], f"{where}: RetrievedMessages={got} (OA-WAKE-3)"
    if "path" in want:
        assert delivery.path == want["path"], f"{where}: delivered on {delivery.path}"


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_session_replay(path: Path) -> None:
    data = load(path)
    server = ServerThread()
    replay = Replay(server.port, data["name"])
    try:
        replay.run(data["steps"])
        replay.finish()
    finally:
        replay.close()
        server.stop()


def test_vectors_are_well_formed() -> None:
    """Every step is one known kind, and every step reference points at an earlier send."""
    assert len(FILES) >= 9
    kinds = {"send", "send_raw_hex", "expect", "expect_closed", "close", "expect_wakeup"}
    for path in FILES:
        steps = load(path)["steps"]
        for n, step in enumerate(steps, start=1):
            assert len(kinds & step.keys()) == 1, (path.name, n, step)
            for value in json.dumps(step.get("expect", step.get("expect_wakeup", {}))).split('"'):
                match = _REF.match(value)
                if match:
                    target = int(match.group(2))
                    assert target < n and "send" in steps[target - 1], (path.name, n, value)
            if "expect" in step or "expect_wakeup" in step:
                assert step.get("requirements"), (path.name, n)
