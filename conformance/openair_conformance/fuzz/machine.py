"""The hypothesis state machine of FUZZ-001 and the bridge from its thread to the case's loop.

Hypothesis drives synchronous code, and the harness is asyncio: `Bridge.run` runs hypothesis in
a worker thread, and every step hands one coroutine to the case's event loop
(`asyncio.run_coroutine_threadsafe`) and blocks until it is done. The loop is otherwise idle, so
the model and the harness are only ever touched by one thread at a time.

Outcomes of a step:
- `Divergence` (the server broke a rule, or a quick `Fail` such as a lost connection): hypothesis
  shrinks the example and replays the smallest one (its frames go to the case's trace).
- `Abort` (a deadline passed, a setup step was refused, a harness error, the time budget ran
  out, or the case was cancelled): hypothesis stops at once; shrinking would wait the deadline
  again and again. The cause decides the verdict.

Shrinking gets `shrink_budget` seconds after the first divergence; when they run out, the
shortest divergence seen so far is reported, with the frames of its example.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
import time
from collections.abc import Coroutine
from dataclasses import dataclass, field
from typing import Any, TypeVar

from hypothesis import HealthCheck, Phase, Verbosity, seed, settings
from hypothesis import strategies as st
from hypothesis.control import current_build_context
from hypothesis.errors import Flaky
from hypothesis.reporting import with_reporter
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    precondition,
    rule,
    run_state_machine_as_test,
)

from openair_conformance.fuzz.example import (
    LOST,
    MODULES,
    SWAPPED,
    Bind,
    Disconnect,
    Divergence,
    Example,
    Post,
    Retrieval,
    Subscription,
)
from openair_conformance.harness import CaseContext
from openair_conformance.harness.trace import Trace
from openair_conformance.model import Fail, TraceEntry

__all__ = ["Abort", "Bridge", "FuzzMachine", "Outcome"]

T = TypeVar("T")

STEPS = 12
BOARDS = ("WB1", "WB2")
TYPES = ("A", "B", "A.B", "B.A", "A.A", "C", "a.b", "A.B.C")
PATTERNS = ("A", "B", "A.B", "A.*", "*", "*.B", "A*", "*B*", "B.*", "a.b", "a.*", "A.B.*")
TRIGGER_FROM = (None, "WB1", "WB2", "wb2", "any", "*", "", "AIRCentral")
SELF_FLAGS = (None, "yes", "YES", "no")
POSTERS = (*MODULES, "stranger")
CC_TOKENS = (*MODULES, "poster", "nobody", "stranger", SWAPPED)
SEPARATORS = (";", " ; ", ";\t", ";;")
LATEST = (None, 0, 1, 2, 5)


class Abort(BaseException):
    """Stop hypothesis at once (a BaseException, so that it is neither caught nor shrunk).

    `cause` is the exception that made the step stop, or None when the time budget ran out or
    the case was cancelled.
    """

    def __init__(self, cause: BaseException | None) -> None:
        super().__init__(str(cause) if cause is not None else "time budget")
        self.cause = cause
        self.steps: tuple[str, ...] = ()
        self.entries: tuple[TraceEntry, ...] = ()  # the trace of the example it stopped


@dataclass(slots=True)
class Outcome:
    """How a fuzzing run ended: no failure, a (shrunk) divergence, or an abort."""

    examples: int = 0
    divergence: Divergence | None = None
    abort: Abort | None = None
    flaky: bool = False
    shrunk: bool = False
    hypothesis_notes: list[str] = field(default_factory=list)


class Bridge:
    """Runs the state machine in a worker thread against the case's event loop."""

    def __init__(
        self,
        ctx: CaseContext,
        loop: asyncio.AbstractEventLoop,
        *,
        seed: int | str,
        examples: int,
        budget: float,
        shrink_budget: float,
    ) -> None:
        self.ctx = ctx
        self.loop = loop
        self.seed = seed
        self.examples = examples
        self.budget = budget
        self.shrink_budget = shrink_budget
        self.found_at: float | None = None  # when the first divergence was seen
        self.started = time.monotonic()
        self.count = 0
        self.best: Divergence | None = None
        self.aborted: Abort | None = None  # the first abort; every later step aborts too
        self.open: list[Example] = []
        self._lock = threading.Lock()
        self._stopped = False
        self._pending: concurrent.futures.Future[Any] | None = None

    # -- the thread side ----------------------------------------------------------------------

    def run(self) -> Outcome:
        """Run hypothesis (in the worker thread) and return how it ended."""
        factory = seed(self.seed)(lambda: FuzzMachine(self))
        outcome = Outcome()
        try:
            with with_reporter(_silent):  # the machine keeps readable steps of its own
                # Any callable returning a machine is a factory (hypothesis' documentation).
                run_state_machine_as_test(factory, settings=self.settings())  # type: ignore[arg-type]
        except Abort as exc:
            outcome.abort, outcome.divergence = exc, self.best
        except Divergence as exc:
            outcome.divergence, outcome.shrunk = exc, True
            outcome.hypothesis_notes = list(getattr(exc, "__notes__", ()))
        except Flaky:
            # An abort in the middle of an example can surface as hypothesis' complaint that
            # the example drew less than before: then the abort decides. Otherwise a failure
            # did not happen again on replay.
            if self.aborted is not None:
                outcome.abort, outcome.divergence = self.aborted, self.best
            elif self.best is not None:
                outcome.divergence, outcome.flaky = self.best, True
            else:
                raise
        outcome.examples = self.count
        return outcome

    def settings(self) -> settings:
        """The hypothesis settings: our own, whatever profile the caller loaded."""
        return settings(
            parent=settings.get_profile("default"),
            max_examples=max(1, self.examples),
            stateful_step_count=STEPS,
            database=None,
            deadline=None,
            derandomize=False,
            phases=(Phase.generate, Phase.shrink),
            report_multiple_bugs=False,
            print_blob=False,
            verbosity=Verbosity.quiet,
            suppress_health_check=list(HealthCheck),
        )

    def call(self, coro: Coroutine[Any, Any, T], *, budgeted: bool = True) -> T:
        """Run a coroutine on the case's loop and return its value (see the module doc)."""
        with self._lock:
            if self._stopped or (budgeted and (self._late() or self.aborted is not None)):
                coro.close()
                raise self._abort(None)
            future = asyncio.run_coroutine_threadsafe(coro, self.loop)
            self._pending = future
        began = time.monotonic()
        try:
            return future.result()
        except Divergence:
            raise
        except Fail as exc:
            if time.monotonic() - began < self.ctx.deadline:  # refused, lost, undecodable
                raise Divergence(exc.message, expected=exc.expected) from exc
            raise self._abort(exc) from exc  # a deadline passed: do not wait for it again
        except Exception as exc:
            raise self._abort(exc) from exc
        finally:
            self._pending = None

    def _late(self) -> bool:
        now = time.monotonic()
        shrinking = self.found_at is not None and now - self.found_at > self.shrink_budget
        return shrinking or now - self.started > self.budget

    def _abort(self, cause: BaseException | None) -> Abort:
        if self.aborted is None:
            self.aborted = Abort(cause)
        return self.aborted

    def new_example(self) -> Example:
        """Start an example; the final replay of hypothesis records into the case's trace."""
        self.count += 1
        final = current_build_context().is_final
        ctx = self.ctx if final else self._sub_context()
        example = Example(ctx, self.count)
        with self._lock:
            self.open.append(example)
        try:
            self.call(example.start())
        except Abort as exc:
            self.keep_trace(exc, example)
            raise
        return example

    def keep_trace(self, exc: Abort | Divergence, example: Example) -> None:
        """Keep the trace of the example an exception stopped, unless it is the case's own."""
        if example.ctx is not self.ctx and not exc.entries:
            exc.entries = example.ctx.trace.entries

    def _sub_context(self) -> CaseContext:
        """A context whose trace is thrown away: passing examples need no evidence."""
        ctx = self.ctx
        return CaseContext(
            case=ctx.case,
            target=ctx.target,
            rtt=ctx.rtt,
            timeout_scale=ctx.timeout_scale,
            server=ctx.server,
            run_id=ctx.run_id,
            trace=Trace(),
        )

    def finish(self, example: Example, steps: list[str]) -> None:
        """Close an example and note its steps (until the first divergence, and the final)."""
        final = example.ctx is self.ctx
        if self.best is None or final:
            lines = "\n".join(f"  {n}. {line}" for n, line in enumerate(steps, 1))
            text = f"example {example.index}{' (final)' if final else ''}:\n{lines}"
            self.loop.call_soon_threadsafe(self.ctx.note, text)
        self.call(example.close(), budgeted=False)  # Abort if stopped: closed on the loop
        with self._lock:
            self.open.remove(example)

    def diverged(self, exc: Divergence, example: Example) -> None:
        """Remember the shortest divergence seen (reported if shrinking cannot finish)."""
        if self.found_at is None:
            self.found_at = time.monotonic()
        if self.best is None or len(exc.steps) <= len(self.best.steps):  # later: simpler
            self.keep_trace(exc, example)
            self.best = exc

    # -- the loop side ------------------------------------------------------------------------

    def stop(self) -> None:
        """Make the worker thread stop at its next step; cancel the step running now."""
        with self._lock:
            self._stopped = True
            if self._pending is not None:
                self._pending.cancel()

    async def close_examples(self) -> None:
        """Close the connections of examples the worker did not finish (on the loop)."""
        with self._lock:
            left, self.open = list(self.open), []
        for example in left:
            await example.close()


class FuzzMachine(RuleBasedStateMachine):
    """Random bind/subscribe/post/retrieve/disconnect steps, each checked against the model."""

    def __init__(self, bridge: Bridge) -> None:
        super().__init__()
        self.bridge = bridge
        self.steps: list[str] = []
        self.example = bridge.new_example()

    def _do(self, lines: list[str], step: Coroutine[Any, Any, None]) -> None:
        self.example.begin(len(self.steps) + 1)
        self.steps += lines
        try:
            self.bridge.call(step)
        except Divergence as exc:
            exc.message = self.example.short(exc.message)
            exc.steps = tuple(self.steps)
            self.bridge.diverged(exc, self.example)
            raise
        except Abort as exc:
            if not exc.steps:  # the first step it stopped
                exc.steps = tuple(self.steps)
                self.bridge.keep_trace(exc, self.example)
            raise

    def _bind(self, module: str, listen: bool) -> None:
        step = Bind(module=module, listen=listen)
        self._do([step.describe()], self.example.bind(step))

    def _subscription(self, module: str, data: st.DataObject) -> Subscription:
        form = data.draw(st.sampled_from(("bare", "module")), label="form")
        return Subscription(
            module=module,
            triggers=tuple(data.draw(_TRIGGERS, label="triggers")),
            form=form,
            flag=data.draw(st.sampled_from(SELF_FLAGS), label="flag") if form == "module" else None,
        )

    @initialize(listen=st.lists(st.booleans(), min_size=1, max_size=len(MODULES)), data=st.data())
    def start(self, listen: list[bool], data: st.DataObject) -> None:
        """Begin with one to three bound, registered modules, so that most posts route."""
        pairs = [
            (Bind(module=label, listen=how), self._subscription(label, data))
            for label, how in zip(MODULES, listen, strict=False)
        ]
        lines = [line for bind, sub in pairs for line in (bind.describe(), sub.describe())]
        self._do(lines, self.example.open_all(pairs))

    @precondition(lambda self: bool(self.example.unbound()))
    @rule(data=st.data(), listen=st.booleans())
    def bind(self, data: st.DataObject, listen: bool) -> None:
        """Bind a module that is not bound (again, after a disconnect)."""
        self._bind(data.draw(st.sampled_from(self.example.unbound()), label="module"), listen)

    @precondition(lambda self: bool(self.example.bound()))
    @rule(data=st.data())
    def subscribe(self, data: st.DataObject) -> None:
        """Replace the registration of a bound module."""
        module = data.draw(st.sampled_from(self.example.bound()), label="module")
        step = self._subscription(module, data)
        self._do([step.describe()], self.example.subscribe(step))

    @rule(
        poster=st.sampled_from(POSTERS),
        via_stranger=st.booleans(),
        board=st.sampled_from(BOARDS),
        suffix=st.sampled_from(TYPES),
        cc=st.lists(st.sampled_from(CC_TOKENS), max_size=3),
        sep=st.sampled_from(SEPARATORS),
    )
    def post(
        self, poster: str, via_stranger: bool, board: str, suffix: str, cc: list[str], sep: str
    ) -> None:
        """Post from a module, or on the unbound connection with any `from`, with a cc list."""
        self._post(poster, via_stranger, board, suffix, cc, sep)

    @precondition(lambda self: bool(self.example.bound()))
    @rule(
        data=st.data(),
        poster=st.sampled_from(POSTERS),
        board=st.sampled_from(BOARDS),
        suffix=st.sampled_from(TYPES),
        sep=st.sampled_from(SEPARATORS),
    )
    def post_cc(self, data: st.DataObject, poster: str, board: str, suffix: str, sep: str) -> None:
        """Post with a cc that names a bound module (cc is the rule most servers get wrong)."""
        named = data.draw(st.sampled_from(self.example.bound()), label="named")
        more = data.draw(st.lists(st.sampled_from(CC_TOKENS), max_size=2), label="more")
        self._post(poster, False, board, suffix, [named, *more], sep)

    def _post(
        self, poster: str, via_stranger: bool, board: str, suffix: str, cc: list[str], sep: str
    ) -> None:
        step = Post(
            poster=poster,
            via_stranger=via_stranger or poster not in self.example.live,
            board=board,
            suffix=suffix,
            cc=tuple(poster if token == "poster" else token for token in cc),
            sep=sep,
        )
        self._do([step.describe()], self.example.post(step))

    @rule(
        board=st.sampled_from(BOARDS),
        pattern=st.sampled_from(PATTERNS),
        sender=st.sampled_from((None, None, "m0", "m1", "stranger")),
        latest=st.sampled_from(LATEST),
        as_attr=st.booleans(),
        addressed=st.booleans(),
    )
    def retrieve(
        self,
        board: str,
        pattern: str,
        sender: str | None,
        latest: int | None,
        as_attr: bool,
        addressed: bool,
    ) -> None:
        """Retrieve by type pattern, sender and latest (element or attribute)."""
        step = Retrieval(
            board=board,
            pattern=pattern,
            sender=sender,
            latest=latest,
            as_attr=as_attr,
            addressed=addressed,
        )
        self._do([step.describe()], self.example.retrieve(step))

    @precondition(lambda self: bool(self.example.bound()))
    @rule(data=st.data())
    def disconnect(self, data: st.DataObject) -> None:
        """Close a bound module: its Lost notice wakes LOST triggers, its name leaves cc."""
        step = Disconnect(module=data.draw(st.sampled_from(self.example.bound()), label="module"))
        self._do([step.describe()], self.example.disconnect(step))

    def teardown(self) -> None:
        """Close the example's connections and note its steps."""
        self.bridge.finish(self.example, self.steps)


def _silent(_: object) -> None:
    """Drop hypothesis' own report (it would print to stdout)."""


_TRIGGERS = st.lists(
    st.tuples(st.sampled_from((*PATTERNS, LOST)), st.sampled_from(TRIGGER_FROM)), max_size=3
)
