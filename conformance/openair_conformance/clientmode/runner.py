"""Run one scenario: start the peer and the shim, play the steps, check the wire, clean up.

`ScenarioRun.run()` returns normally (pass) or raises `Fail`, `Inconclusive` or any other
exception (a kit or scenario bug: ERROR), exactly like a server-mode case, so the engine judges
both the same way. Every shim line, every frame on every tapped connection and the kit's own
traffic go to one trace; the shim's standard error is added at the end.

Waits are bounded: a shim command by the library's own timeouts plus a margin, a delivery's
answer and the final settling by the deadline (`deadline_s` × timeout scale).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable, Sequence
from typing import Any

from openair.catalogue import load_catalogue
from openair_conformance.clientmode.kit import DEFAULT_REPLY, KitClient, delivery, message_json
from openair_conformance.clientmode.peers import Peer, start_peer
from openair_conformance.clientmode.scenario import Expect, Scenario, Step
from openair_conformance.clientmode.streamsteps import stream_steps
from openair_conformance.clientmode.tap import Capture, TapConn, WireFrame
from openair_conformance.clientmode.values import MISSING, Values, evaluate, lookup, render
from openair_conformance.clientmode.wirechecks import WireContext, run_checks
from openair_conformance.harness.trace import Trace
from openair_conformance.model import Fail, NotApplicable
from openair_conformance.shim.driver import ShimDriver, ShimError
from openair_conformance.verdicts import LATENCY_MEASURE

__all__ = ["DEADLINE_S", "LATENCY_MEASURE", "ScenarioRun"]

DEADLINE_S = 2.0  # for an answer the kit waits on (a delivery's, the final settling)
COMMAND_S = 15.0  # for a shim command: the library's own request timeout (10 s) plus a margin
READY_S = 10.0  # for the shim's ready line


def _requirement_text(req: str) -> str:
    found = load_catalogue().get(req) if req else None
    return f"{req}: {found.text}" if found is not None else req


class ScenarioRun:
    """The state of one scenario while it runs."""

    def __init__(
        self,
        scenario: Scenario,
        *,
        shim: Sequence[str],
        run_id: str,
        timeout_scale: float = 1.0,
        env: dict[str, str] | None = None,
    ) -> None:
        self.scenario = scenario
        self.shim_argv = list(shim)
        self.scale = timeout_scale
        self.env = env
        self.trace = Trace()
        token = scenario.info.id.replace("-", "")
        self.module = f"Lib_{run_id}_{token}"
        self.values = Values(T=f"Conf.Client.R{run_id}.{token}", module=self.module,
                             kit=f"Kit_{run_id}_{token}")  # fmt: skip
        self.measurements: list[tuple[str, float]] = []
        self.peer: Peer | None = None
        self.kit: KitClient | None = None
        self.driver: ShimDriver | None = None
        self.shim_closed = False
        self.bound_port = -1
        self._listeners: dict[str, TapConn] = {}
        self._kit_posted: dict[str, int] = {}  # message id -> postedTime (ns)
        self._steps: dict[str, Callable[[Step], Awaitable[None]]] = {
            "connect": self._connect,
            "register": self._register,
            "post": self._post,
            "post-noreply": self._post,
            "retrieve": self._retrieve,
            "await-wakeup": self._await_wakeup,
            "close": self._close,
            "kit-post": self._kit_post,
            "kit-retrieve": self._kit_retrieve,
            "deliver": self._deliver,
            "settle": self._settle,
        }
        self._steps.update(stream_steps(self))  # call, require, kit streams (streamsteps.py)
        self.background: list[asyncio.Task[None]] = []  # kit writes that a later step awaits

    @property
    def deadline(self) -> float:
        return DEADLINE_S * self.scale

    # -- running ---------------------------------------------------------------------------------

    async def run(self) -> None:
        """Play the scenario; raises Fail (or Inconclusive, or a bug) as a case does."""
        try:
            await self._start()
            try:
                for step in self.scenario.steps:
                    self.trace.note(f"step {step.kind} (line {step.line})", "kit")
                    await self._steps[step.kind](step)
            except Fail as failure:
                raise self._with_wire_problems(failure) from None
            await self._check_wire()
        finally:
            await self._cleanup()

    def _with_wire_problems(self, failure: Fail) -> Fail:
        """Add what the wire checks already see to a step's failure: often the cause."""
        if self.peer is None or not self.scenario.wire_checks:
            return failure
        problems = run_checks(self.scenario.wire_checks, self.peer.tap.capture,
                              self._wire_context(final=False))  # fmt: skip
        if not problems:
            return failure
        lines = [f"[{p.check}] {p.requirement}: {p.text}" for p in problems[:20]]
        message = f"{failure.message}\nSeen on the wire before that:\n" + "\n".join(lines)
        widened = Fail(message, expected=failure.expected)
        indexes = [p.trace_index for p in problems if p.trace_index is not None]
        earliest = min(indexes, default=None)
        widened.divergence = failure.divergence
        if earliest is not None and (failure.divergence is None or earliest < failure.divergence):
            widened.divergence = earliest
        return widened

    def _wire_context(self, *, final: bool) -> WireContext:
        assert self.peer is not None
        return WireContext(module=self.module, advertised=self.peer.advertised,
                           stamp_window_s=DEADLINE_S * self.scale, final=final)  # fmt: skip

    async def _start(self) -> None:
        capture = Capture(trace=self.trace)
        self.peer = await start_peer(self.scenario.peer, capture, self.values.expand)
        self.trace.note(
            f"peer {self.scenario.peer.kind}: server on port {self.peer.server.port}, the library "
            f"connects to the kit's tap on port {self.peer.port}; the server advertises "
            f"{', '.join(sorted(self.peer.advertised)) or 'no extension'}",
            "kit",
        )
        self.kit = KitClient(self.peer.server_address, self.trace,
                             name=self.values.expand("{kit}"), timeout=self.deadline)  # fmt: skip
        self.driver = ShimDriver(self.shim_argv, on_line=self._traced_line, env=self.env)
        try:
            info = await self.driver.start(READY_S * self.scale)
        except ShimError as exc:
            raise self._fail(f"the shim did not start: {exc}") from exc
        self.trace.note(f"shim ready: {info.label} ({info.protocol})", "shim")

    def _traced_line(self, direction: str, text: str) -> None:
        self.trace.add("shim", direction, "command" if direction == "out" else "answer", text)

    def _fail(self, message: str, requirement: str = "", index: int | None = None) -> Fail:
        failure = Fail(message, expected=_requirement_text(requirement))
        failure.divergence = index if index is not None else max(0, len(self.trace) - 1)
        return failure

    async def _cleanup(self) -> None:
        for task in self.background:
            task.cancel()
        for outcome in await asyncio.gather(*self.background, return_exceptions=True):
            if isinstance(outcome, Exception):
                self.trace.note(f"a background kit step failed: {outcome}", "kit")
        driver = self.driver
        if driver is not None:
            if driver.running and not self.shim_closed:
                try:
                    await driver.command("close", {}, 5.0 * self.scale)
                except ShimError as exc:
                    self.trace.note(f"closing the shim: {exc}", "shim")
            code = await driver.close(5.0 * self.scale)
            if code is None:
                self.trace.note("the shim did not exit; it was killed", "shim")
            if driver.stderr_text.strip():
                self.trace.note(f"the shim's standard error:\n{driver.stderr_text}", "shim")
        if self.kit is not None:
            await self.kit.close()
        if self.peer is not None:
            await self.peer.stop()

    # -- shim commands ---------------------------------------------------------------------------

    async def _command(self, step: Step, cmd: str, fields: dict[str, Any], timeout: float) -> Any:
        """Send a shim command, judge its outcome, save it, check its expects; return the result."""
        assert self.driver is not None
        try:
            answer = await self.driver.command(cmd, fields, timeout)
        except ShimError as exc:
            raise self._fail(f"{cmd} (line {step.line}): {exc}") from exc
        self._judge_outcome(step, cmd, answer)
        return {k: v for k, v in answer.items() if k not in ("seq", "ok")}

    def _judge_outcome(self, step: Step, cmd: str, answer: dict[str, Any]) -> None:
        outcome = step.get("outcome", "ok")
        requirement = step.get("requirement")
        if answer["ok"]:
            if outcome == "error":
                raise self._fail(f"{cmd} (line {step.line}) succeeded; it had to fail", requirement)
            return
        error = answer["error"]
        said = f"{error['code']}: {error['message']}"
        if outcome == "ok":
            raise self._fail(f"{cmd} (line {step.line}) failed: {said}", requirement)
        wanted = step.get("error-code")
        if outcome == "error" and wanted and error["code"] != wanted:
            raise self._fail(
                f"{cmd} (line {step.line}) reported {said}; the error had to be {wanted}",
                requirement,
            )

    def _check(self, step: Step, result: Any) -> None:
        """Apply the step's expects to its result and save it under `as`."""
        if step.has("as"):
            self.values.save(step.get("as"), result)
        for expect in step.expects:
            self._expect(step, expect, result)

    def _expect(self, step: Step, expect: Expect, result: Any) -> None:
        wanted = self.values.expand(expect.value)
        actual = lookup(result, expect.path)
        if evaluate(expect, actual, wanted):
            return
        if actual is MISSING and ".attachments" in f".{expect.path}":
            raise NotApplicable("the shim does not report attachments (PROTOCOL.md)")
        shown = render(actual) if actual is not MISSING else "absent"
        raise self._fail(
            f"{step.kind} (line {step.line}): {expect.path} is {shown!r}; "
            f"expected {expect.test} {wanted!r} (line {expect.line})",
            expect.requirement,
        )

    async def _connect(self, step: Step) -> None:
        assert self.peer is not None
        fields = {
            "host": "127.0.0.1",
            "port": self.peer.port,
            "name": self.module,
            "bind": step.flag("bind", True),
            "listen": step.flag("listen", True),
            "callback": step.flag("callback", True),
            "extensions": step.get("extensions", "noreply pipelining usec gettime").split(),
        }
        result = await self._command(step, "connect", fields, COMMAND_S * self.scale)
        self.bound_port = int(result.get("bound_port", -1))
        self._check(step, result)

    async def _register(self, step: Step) -> None:
        fields = {
            "triggers": [self._trigger(t) for t in step.children("trigger")],
            "retrieves": [self._spec(r) for r in step.children("retrieve")],
            "allowselftriggering": step.flag("allowselftriggering", False),
        }
        self._check(step, await self._command(step, "register", fields, COMMAND_S * self.scale))

    def _trigger(self, attrs: dict[str, str]) -> dict[str, Any]:
        return {
            "type": self.values.expand(attrs["type"]),
            "from": self.values.expand(attrs.get("from", "")),
            "after": int(attrs.get("after", "0")),
        }

    def _spec(self, attrs: dict[str, str]) -> dict[str, Any]:
        spec: dict[str, Any] = {}
        for key in ("whiteboard", "type", "sender", "content"):
            if key in attrs:
                spec[key] = self.values.expand(attrs[key])
        for key in ("latest", "lastmsec"):
            if key in attrs:
                spec[key] = int(attrs[key])
        return spec

    async def _post(self, step: Step) -> None:
        cc = self.values.expand(step.get("cc"))
        priority = step.get("priority")
        fields = {
            "to": self.values.expand(step.get("to")),
            "type": self.values.expand(step.get("type")),
            "content": self.values.expand(step.get("content")),
            "xml": step.flag("xml", False),
            "cc": [name.strip() for name in cc.split(";") if name.strip()],
            "priority": float(priority) if priority else None,
        }
        result = await self._command(step, step.kind, fields, COMMAND_S * self.scale)
        self._check(step, result)

    async def _retrieve(self, step: Step) -> None:
        fields = {
            "specs": [self._spec(s) for s in step.children("spec")],
            "to": self.values.expand(step.get("to", "AIRCentral")),
        }
        self._check(step, await self._command(step, "retrieve", fields, COMMAND_S * self.scale))

    async def _await_wakeup(self, step: Step) -> None:
        timeout_ms = int(int(step.get("timeout-ms", "5000")) * self.scale)
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout_ms / 1000
        keep_phase = step.flag("phase-updates", False)
        while True:
            left = max(1, int((end - loop.time()) * 1000))
            fields = {"timeout_ms": left}
            result = await self._command(step, "await-wakeup", fields, left / 1000 + 5 * self.scale)
            wakeup = result.get("wakeup")
            if wakeup is None or keep_phase or wakeup.get("trigger") is not None:
                break
            self.trace.note("a phase update (no TriggerMessage); waiting on", "kit")
        if wakeup is not None:
            self._measure(wakeup)
        self._check(step, wakeup if wakeup is not None else result)

    def _measure(self, wakeup: dict[str, Any]) -> None:
        trigger = wakeup.get("trigger")
        posted = self._kit_posted.get(trigger["id"]) if isinstance(trigger, dict) else None
        if posted is not None and not any(n == LATENCY_MEASURE for n, _ in self.measurements):
            self.measurements.append((LATENCY_MEASURE, (wakeup["received_ns"] - posted) / 1e6))

    async def _close(self, step: Step) -> None:
        assert self.driver is not None
        result = await self._command(step, "close", {}, COMMAND_S * self.scale)
        self.shim_closed = True
        self._check(step, result)
        code = await self.driver.close(5.0 * self.scale)
        if code != 0:
            raise self._fail(f"close (line {step.line}): the shim exited with code {code}, not 0")

    # -- the kit's own steps ---------------------------------------------------------------------

    async def _kit_post(self, step: Step) -> None:
        assert self.kit is not None
        priority = step.get("priority")
        sent = await self.kit.post(
            self.values.expand(step.get("to")),
            self.values.expand(step.get("type")),
            self.values.expand(step.get("content")),
            cc=self.values.expand(step.get("cc")),
            priority=float(priority) if priority else None,
        )
        if sent.posted is not None:
            self._kit_posted[sent.id] = sent.posted.ms * 1_000_000
        self._check(step, message_json(sent))

    async def _kit_retrieve(self, step: Step) -> None:
        assert self.kit is not None
        found = await self.kit.retrieve(
            self.values.expand(step.get("whiteboard")),
            self.values.expand(step.get("type")),
            int(step.get("latest", "1")),
        )
        self._check(step, {"messages": [message_json(m) for m in found]})

    async def _settle(self, step: Step) -> None:
        assert self.peer is not None
        await self.peer.tap.capture.settled(self.deadline)

    async def _channel(self, step: Step) -> TapConn:
        assert self.peer is not None
        if step.get("via") == "callback":
            conn = await self.peer.tap.wait_callback(self.deadline)
            if conn is None:
                raise self._fail(
                    f"deliver (line {step.line}): the library has no open callback connection",
                    "OA-SESS-7",
                )
            return conn
        name = step.get("connection")
        if name and name in self._listeners and not self._listeners[name].closed:
            return self._listeners[name]
        if self.bound_port <= 0:
            raise self._fail(f"deliver (line {step.line}): the module has no bound port to use")
        try:
            conn = await self.peer.tap.open_listener("127.0.0.1", self.bound_port, self.deadline)
        except (OSError, TimeoutError) as exc:
            raise self._fail(
                f"deliver (line {step.line}): cannot connect to the bound port "
                f"{self.bound_port}: {exc}",
                "OA-DELIV-10",
            ) from exc
        if name:
            self._listeners[name] = conn
        return conn

    async def _deliver(self, step: Step) -> None:
        kind = step.get("kind")
        conn = await self._channel(step)
        frame, request = delivery(
            kind,
            module=self.module,
            whiteboard=self.values.expand(step.get("from", "WB1")),
            trigger_type=self.values.expand(step.get("trigger-type", "{T}.Delivered")),
            lasttrigger=self.values.expand(step.get("lasttrigger", "{T}.*")),
            sender=self.values.expand("{kit}"),
            now_ns=time.time_ns(),
        )
        requirement = step.get("requirement")
        answer = await self._answer(step, conn.inject(frame), requirement)
        self._judge_answer(step, kind, request, answer, requirement)
        result = {
            "request": message_json(request) if request is not None else None,
            "reply": message_json(answer.message) if answer.message is not None else None,
        }
        self._check(step, result)

    async def _answer(
        self, step: Step, future: asyncio.Future[WireFrame], requirement: str
    ) -> WireFrame:
        try:
            return await asyncio.wait_for(future, self.deadline)
        except TimeoutError:
            raise self._fail(
                f"deliver (line {step.line}): no answer within {self.deadline:.1f} s",
                requirement,
            ) from None
        except ConnectionError as exc:
            raise self._fail(
                f"deliver (line {step.line}): the connection closed before an answer: {exc}",
                requirement,
            ) from exc

    def _judge_answer(
        self, step: Step, kind: str, request: Any, answer: WireFrame, requirement: str
    ) -> None:
        wanted = step.get("expect-reply", DEFAULT_REPLY[kind])
        got = answer.message
        if got is None:
            raise self._fail(f"deliver (line {step.line}): the answer does not decode: "
                             f"{answer.error}", requirement, answer.trace_index)  # fmt: skip
        if got.type != wanted:
            raise self._fail(f"deliver (line {step.line}): the {kind} was answered {got.type}, "
                             f"not {wanted}", requirement, answer.trace_index)  # fmt: skip
        if request is not None and got.isresponse != request.id:
            raise self._fail(
                f"deliver (line {step.line}): the answer's isresponse is {got.isresponse!r}, "
                f"not the request's id {request.id!r}",
                "OA-DELIV-4",
                answer.trace_index,
            )

    # -- the wire --------------------------------------------------------------------------------

    async def _check_wire(self) -> None:
        assert self.peer is not None
        capture = self.peer.tap.capture
        await capture.settled(self.deadline)
        if not self.scenario.wire_checks:
            return
        problems = run_checks(self.scenario.wire_checks, capture, self._wire_context(final=True))
        if not problems:
            self.trace.note(f"wire checks passed: {', '.join(self.scenario.wire_checks)}", "kit")
            return
        lines = [f"[{p.check}] {p.requirement}: {p.text}" for p in problems]
        first = problems[0]
        raise self._fail(
            f"{len(problems)} problem(s) on the wire:\n" + "\n".join(lines[:20]),
            first.requirement,
            first.trace_index,
        )
