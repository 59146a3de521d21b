"""`CaseContext`: what a case gets to work with — names, deadlines, modules, raw connections.

Deadlines come from the round-trip time the probe measured: `deadline = max(1.0 s, 10 × rtt) ×
timeout_scale`; something that arrives after the deadline but within the grace (1 × deadline, so
before the fail threshold of 2 × deadline) makes the case TIMING; later, or never, makes it FAIL
(OA-GEN-6; README, "Time"). There are no fixed sleeps: cases synchronise on protocol round trips
(`TestModule.barrier`, PING).

Names isolate cases from each other so that they can run in parallel against one server: module
names are `C<run>_<CASEID>_<suffix>` and types live under `Conf.R<run>.<CASEID>` (`type_prefix`).
"""

from __future__ import annotations

import asyncio
import re
import time
from collections.abc import Awaitable, Mapping
from typing import NoReturn, TypeVar

from openair.protocol.message import Message
from openair_conformance.harness.conn import ConnectionLost, DecodeProblem
from openair_conformance.harness.peer import TestModule
from openair_conformance.harness.raw import RawConnection
from openair_conformance.harness.trace import Trace
from openair_conformance.model import CaseInfo, Fail, ServerInfo, Timing

__all__ = [
    "FAIL_FACTOR",
    "GRACE_FACTOR",
    "MIN_DEADLINE",
    "RTT_FACTOR",
    "CaseContext",
    "deadline_for",
    "fail_threshold_for",
]

T = TypeVar("T")

MIN_DEADLINE = 1.0  # seconds
#: Ten round trips: a case's step is a request, its reply and a delivery or two. (It was 100:
#: a target answering in 0.3 s then had 30 s deadlines and 120 s waits for what never comes.)
RTT_FACTOR = 10.0
#: OA-GEN-6: a timed requirement fails when its answer comes later than 2 deadlines; between
#: one and two deadlines it is TIMING, the grey zone. (The grace was 3 deadlines, and an "at once"
#: answer several seconds late was only ever TIMING, which fails no run.)
FAIL_FACTOR = 2.0
GRACE_FACTOR = FAIL_FACTOR - 1.0
_SUFFIX_RE = re.compile(r"^[A-Za-z0-9_]*$")


def deadline_for(rtt: float, timeout_scale: float = 1.0) -> float:
    """Return the deadline in seconds for a round-trip time `rtt` (seconds)."""
    return max(MIN_DEADLINE, RTT_FACTOR * rtt) * timeout_scale


def fail_threshold_for(rtt: float, timeout_scale: float = 1.0) -> float:
    """Return the time after which a timed answer is a failure, not TIMING (OA-GEN-6)."""
    return FAIL_FACTOR * deadline_for(rtt, timeout_scale)


class CaseContext:
    """The per-case view of the run; every frame and note goes to `trace`."""

    def __init__(
        self,
        *,
        case: CaseInfo,
        target: tuple[str, int],
        rtt: float,
        timeout_scale: float,
        server: ServerInfo,
        run_id: str,
        fuzz_examples: int | None = None,
        replay: str | None = None,
        trace: Trace | None = None,
        stream: str = "Stream1",
        secrets: Mapping[str, str] | None = None,
    ) -> None:
        self.case = case
        #: Module names and their secrets for the secure-mode cases (spec 14.3, --auth-secrets).
        self.secrets: Mapping[str, str] = dict(secrets or {})
        self.target = target
        self.rtt = rtt
        self.timeout_scale = timeout_scale
        self.server = server
        self.run_id = run_id
        self.fuzz_examples = fuzz_examples
        self.replay = replay
        self.stream = stream  # the stream the stream cases use (--stream)
        self.trace = trace if trace is not None else Trace()
        self.repro_args: list[str] = []
        self.vacuous_reason = ""
        self._measurements: list[tuple[str, float]] = []
        self._modules: list[TestModule] = []
        self._raws: list[RawConnection] = []
        self._posted_at: dict[str, float] = {}
        #: Components that RESOLVE_REQUEST placed on a port of their own (a legacy server gives
        #: each stream one; OA-SESS-9): name → (host, port). `raw(component=…)` goes there.
        self.component_ports: dict[str, tuple[str, int]] = {}

    # -- names ---------------------------------------------------------------------------------

    @property
    def _case_token(self) -> str:
        return self.case.id.replace("-", "")

    def name(self, suffix: str = "") -> str:
        """Return a module name unique to this case and run: `C<run>_<CASEID>_<suffix>`."""
        if not _SUFFIX_RE.match(suffix):
            raise ValueError(f"name suffix must be letters, digits or _: {suffix!r}")
        base = f"C{self.run_id}_{self._case_token}"
        return f"{base}_{suffix}" if suffix else base

    def in_namespace(self, name: str) -> bool:
        """Return whether a module name belongs to this case and run (`name(...)` made it)."""
        base = self.name()
        return name == base or name.startswith(f"{base}_")

    def check_module_name(self, name: str | None) -> None:
        """Refuse (harness error) a module name no `name(...)` made: cases would interfere."""
        if name is not None and not self.in_namespace(name):
            raise RuntimeError(
                f"case isolation: module name {name!r} is not this case's; use ctx.name(...)"
            )

    def check_post_type(self, type: str) -> None:
        """Refuse (harness error) a posted type outside this run's names, unless the case is
        marked `residue` (it runs after every other case): another case's pattern could match
        what it leaves on a whiteboard."""
        if not self.case.residue and f"R{self.run_id}" not in type:
            raise RuntimeError(
                f"case isolation: type {type!r} is outside the run's names; use ctx.type(...)"
            )

    def type_prefix(self) -> str:
        """Return the type prefix unique to this case and run: `Conf.R<run>.<CASEID>`."""
        return f"Conf.R{self.run_id}.{self._case_token}"

    def type(self, suffix: str) -> str:
        """Return `<type_prefix>.<suffix>`, a type inside this case's subtree."""
        return f"{self.type_prefix()}.{suffix}"

    def barrier_type(self, suffix: str) -> str:
        """Return the type of a barrier sentinel: outside the case subtree, still unique."""
        return f"Conf.R{self.run_id}.Barrier.{self._case_token}.{suffix or 'X'}"

    # -- time ----------------------------------------------------------------------------------

    @property
    def deadline(self) -> float:
        """Seconds to wait for an expected event before it counts as late."""
        return deadline_for(self.rtt, self.timeout_scale)

    @property
    def grace(self) -> float:
        """Seconds to keep waiting after the deadline: arrival then is TIMING, not PASS."""
        return GRACE_FACTOR * self.deadline

    @property
    def fail_threshold(self) -> float:
        """Seconds after which a timed answer is FAIL, not TIMING (OA-GEN-6)."""
        return self.deadline + self.grace

    def judge_elapsed(self, what: str, elapsed: float, *, limit: float | None = None) -> None:
        """Judge an answer that came after `elapsed` s against a timed rule (OA-GEN-6).

        Within `limit` (the deadline): nothing. Within the grace after it: Timing. Later:
        Fail, because an answer that late does not meet an "at once" rule.
        """
        limit = self.deadline if limit is None else limit
        if elapsed <= limit:
            return
        if elapsed > limit * FAIL_FACTOR:
            self.fail(
                f"{what} came after {elapsed:.3f} s, beyond the fail threshold "
                f"{limit * FAIL_FACTOR:.3f} s (2 deadlines, from the measured RTT)",
                expected=f"{what} within {limit:.3f} s",
            )
        self.note(f"{what} arrived after {elapsed:.3f} s (deadline {limit:.3f} s)")
        raise Timing(f"{what} arrived after {elapsed:.3f} s; the deadline is {limit:.3f} s")

    async def wait(
        self, aw: Awaitable[T], *, what: str, expected: str = "", timeout: float | None = None
    ) -> T:
        """Await `aw` under the deadline policy.

        On time: the value. Within the grace: Timing. Never: Fail (`expected` says what was
        allowed). A lost connection or an undecodable message is a Fail too.
        """
        limit = self.deadline if timeout is None else timeout
        grace = GRACE_FACTOR * limit
        task = asyncio.ensure_future(aw)
        started = time.monotonic()
        try:
            done, _ = await asyncio.wait({task}, timeout=limit)
            late = not done
            if late:
                done, _ = await asyncio.wait({task}, timeout=grace)
        finally:
            if not task.done():  # timed out, or the case itself was cancelled
                task.cancel()
        if not done:
            self.fail(f"no {what} within {limit + grace:.2f} s", expected=expected)
        try:
            value = task.result()
        except ConnectionLost as exc:
            self.fail(f"{what}: {exc}", expected=expected)
        except DecodeProblem as exc:
            self.fail(f"{what} could not be decoded: {exc}", expected=expected)
        if late:
            elapsed = time.monotonic() - started
            self.note(f"{what} arrived after {elapsed:.3f} s (deadline {limit:.3f} s)")
            raise Timing(f"{what} arrived after {elapsed:.3f} s; the deadline is {limit:.3f} s")
        return value

    # -- peers ---------------------------------------------------------------------------------

    async def module(
        self,
        suffix: str = "M",
        *,
        listen: bool = True,
        callback: bool = True,
        bind: bool = True,
        extensions: tuple[str, ...] = (),
    ) -> TestModule:
        """Open a module named `name(suffix)`: primary connection, BIND, listener, callback.

        `bind=False` gives an unbound client (no listener, no callback, OA-SESS-16).
        `listen=False` binds with BIND_NOLISTEN. Setup steps the server refuses make the case
        INCONCLUSIVE. Modules are closed when the case ends.
        """
        module = TestModule(self, suffix=suffix, name=self.name(suffix))
        self._modules.append(module)
        await module.open(listen=listen, callback=callback, bind=bind, extensions=extensions)
        return module

    async def raw(self, label: str = "raw", *, component: str = "") -> RawConnection:
        """Open a raw connection labelled `<label>#<n>`: to the main port, or to the port
        `component` resolved to when that is another one (`component_ports`)."""
        address = self.component_ports.get(component, self.target) if component else self.target
        connection = RawConnection(self, label=f"{label}#{len(self._raws) + 1}", address=address)
        self._raws.append(connection)
        await connection.open()
        return connection

    def resolved(self, name: str, location: dict[str, str]) -> None:
        """Remember where RESOLVE_SUCCESS placed `name` (attributes of its `<tcplocation>`).

        Only a port other than the main port is kept: that is where the component's own
        connections must go (OA-SESS-9, OA-SESS-34: a server may give a component its own
        port, and a client learns which only from RESOLVE_SUCCESS).
        """
        host, main_port = self.target
        try:
            port = int(location.get("port", ""))
        except ValueError:
            return
        if port > 0 and port != main_port:
            address = location.get("address") or host
            self.component_ports[name] = (address, port)
            self.note(f"{name} resolved to its own port {address}:{port}; its connections go there")

    # -- evidence ------------------------------------------------------------------------------

    def message(self, type: str, **fields: object) -> Message:
        """Build a message (fields as in `openair.protocol.message.Message`; `from` is `sender`)."""
        return Message(type=type, **fields)  # type: ignore[arg-type]

    def note(self, text: str) -> None:
        """Add a note to the trace."""
        self.trace.note(text)

    def measure(self, name: str, value: float) -> None:
        """Record a measured value (reported with the result and summarised for the run)."""
        self._measurements.append((name, value))

    @property
    def measurements(self) -> tuple[tuple[str, float], ...]:
        """The values measured so far."""
        return tuple(self._measurements)

    def vacuous(self, reason: str) -> None:
        """Say that a pass of this case would prove nothing (e.g. nothing to compare)."""
        self.vacuous_reason = reason
        self.note(f"vacuous: {reason}")

    def fail(self, message: str, *, expected: str = "") -> NoReturn:
        """Raise Fail; the divergence is the last trace entry."""
        exc = Fail(message, expected)
        exc.divergence = len(self.trace) - 1 if len(self.trace) else None
        raise exc

    def check(self, condition: bool, message: str, *, expected: str = "") -> None:
        """Fail with `message` unless `condition` holds."""
        if not condition:
            self.fail(message, expected=expected)

    # -- latency bookkeeping (used by TestModule) ---------------------------------------------

    def posted(self, message_id: str) -> None:
        """Remember when a message was sent, to measure post → wakeup latency."""
        self._posted_at[message_id] = time.monotonic()

    def woken(self, trigger_id: str) -> None:
        """Record the latency of the first wakeup for a message this case sent."""
        sent = self._posted_at.pop(trigger_id, None)
        if sent is not None:
            self.measure("post_to_wakeup_ms", (time.monotonic() - sent) * 1000.0)

    async def aclose(self) -> None:
        """Close every module and raw connection of the case."""
        for module in reversed(self._modules):
            await module.close()
        for connection in self._raws:
            await connection.close()
