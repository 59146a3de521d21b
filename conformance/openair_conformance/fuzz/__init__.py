"""Stateful fuzzing of routing: FUZZ-001 (imported by `registry.load_cases()`).

A hypothesis `RuleBasedStateMachine` (machine.py) drives the server under test with random
bind / subscribe / post (with cc lists) / retrieve / disconnect steps; every wakeup and retrieve
result is compared with a model of the spec (model.py) right after the step that caused it
(example.py). A failure is shrunk to the fewest steps and reported with the seed; `openair
conform HOST:PORT --case FUZZ-001 --replay SEED` runs the same examples again.
"""

from __future__ import annotations

import asyncio
import secrets
from typing import NoReturn

from openair_conformance.fuzz.example import Divergence
from openair_conformance.fuzz.machine import STEPS, Abort, Bridge, Outcome
from openair_conformance.harness import CaseContext
from openair_conformance.model import Fail, Inconclusive, NotApplicable, Timing, TraceEntry
from openair_conformance.registry import case

__all__ = [
    "DEFAULT_EXAMPLES",
    "SHRINK_SECONDS",
    "Abort",
    "Divergence",
    "parse_seed",
    "routing_fuzz",
]

#: Examples per run without --fuzz-examples (about 10–20 s against the reference server).
DEFAULT_EXAMPLES = 25
#: Seconds of shrinking after the first divergence (× --timeout-scale); then the shortest
#: failing example found so far is reported.
SHRINK_SECONDS = 15.0
# The engine stops a case after 60 deadlines, at least 60 s (README, "Time"); fuzzing stops
# generating or shrinking at this share of that, leaving time to close and report.
_BUDGET_SHARE = 0.75


def parse_seed(replay: str | None) -> int | str:
    """Return the hypothesis seed: `--replay` as an integer (or as given), else a random one."""
    if replay is None:
        return secrets.randbelow(2**32)
    text = replay.strip()
    return int(text) if text.isdecimal() else text


@case(
    id="FUZZ-001",
    title="Random bind/subscribe/post/cc/retrieve/disconnect sequences route as the spec says",
    section="8.6",
    requirements=(
        "OA-TRIG-1",
        "OA-TRIG-2",
        "OA-TRIG-4",
        "OA-CC-1",
        "OA-CC-2",
        "OA-CC-3",
        "OA-CC-4",
        "OA-WAKE-4",
        "OA-WAKE-5",
        "OA-WAKE-6",
        "OA-REG-1",
        "OA-REG-6",
        "OA-RET-4",
        "OA-RET-6",
        "OA-SESS-15",
    ),
    serial=True,
    allowed=(
        "every wakeup, lasttrigger and retrieve result exactly as the routing model computes "
        "it from the spec (sections 5, 8 and 9)",
    ),
)
async def routing_fuzz(ctx: CaseContext) -> None:
    """Run hypothesis' state machine against the server, shrinking any divergence.

    Each example binds one to three modules (BIND with a port or BIND_NOLISTEN, each with a
    callback connection), then runs up to 12 random steps: subscribe (bare or module form,
    patterns with wildcards and other case, trigger `from` in any spelling, self-triggering),
    post to WB1/WB2 from a module or on an unbound connection with any `from`, with a cc list
    (modules, unbound names, the poster, a name in other case), retrieve (type, sender, latest
    as element or attribute, with or without `from`), disconnect (the Lost notice) and bind
    again. After each step every live module is synced with a sentinel and its wakeups are
    compared with the model: who is woken, once, with which `lasttrigger`.

    `--fuzz-examples N` sets the number of examples (default 25); `--replay SEED` reruns a seed.
    On a divergence the message gives the seed, the shrunk steps and expected vs observed;
    shrinking stops after 15 s (× --timeout-scale) with the shortest example found so far.
    """
    chosen = parse_seed(ctx.replay)
    examples = ctx.fuzz_examples if ctx.fuzz_examples is not None else DEFAULT_EXAMPLES
    ctx.repro_args += ["--replay", str(chosen), "--fuzz-examples", str(examples)]
    ctx.note(f"seed {chosen}: {examples} example(s) of at most {STEPS} steps")
    budget = _BUDGET_SHARE * max(60.0, 60.0 * ctx.deadline)
    bridge = Bridge(
        ctx,
        asyncio.get_running_loop(),
        seed=chosen,
        examples=examples,
        budget=budget,
        shrink_budget=SHRINK_SECONDS * ctx.timeout_scale,
    )
    try:
        outcome = await asyncio.to_thread(bridge.run)
    finally:
        bridge.stop()
        await bridge.close_examples()
    _judge(ctx, chosen, outcome)


def _judge(ctx: CaseContext, chosen: int | str, outcome: Outcome) -> None:
    """Turn the outcome into the case's verdict (return: pass)."""
    ctx.measure("fuzz_runs", float(outcome.examples))  # examples run, shrinking included
    for note in outcome.hypothesis_notes:
        ctx.note(f"hypothesis: {note}")
    abort = outcome.abort
    if abort is not None and abort.cause is not None:
        ctx.note(f"fuzzing stopped early: {abort.cause!r}")
    if outcome.divergence is not None:
        _fail(ctx, chosen, outcome)
    if abort is None:
        ctx.note(f"seed {chosen}: {outcome.examples} example(s) run, no divergence")
        return
    steps = _steps(abort.steps)
    cause = abort.cause
    if cause is None:
        ctx.note(f"time budget reached after {outcome.examples} example(s) run; no divergence")
        return
    where = f"(seed {chosen}; steps so far:\n{steps})"
    _copy(ctx, abort.entries, "the frames of the example that stopped follow")
    if isinstance(cause, Fail):
        exc = Fail(f"{cause.message} {where}", cause.expected)
        exc.divergence = len(ctx.trace) - 1 if len(ctx.trace) else None
        raise exc
    if isinstance(cause, Timing | Inconclusive | NotApplicable):
        raise type(cause)(f"{cause} {where}")
    raise cause


def _fail(ctx: CaseContext, chosen: int | str, outcome: Outcome) -> NoReturn:
    found = outcome.divergence
    assert found is not None
    if outcome.shrunk:
        how = f"shrunk to {len(found.steps)} step(s)"
    elif outcome.flaky:
        how = "it did not happen again when replayed: the server is not deterministic here"
    else:
        how = "the shortest failing example found before shrinking was stopped (time budget)"
    at = found.steps[-1] if found.steps else "setting up the example"
    message = (
        f"the server diverged from the routing model (seed {chosen}; {how})\n"
        f"steps:\n{_steps(found.steps)}\n"
        f"at step {len(found.steps)} ({at}): {found.message}"
    )
    exc = Fail(message, found.expected)
    exc.divergence = _evidence(ctx, found, final=outcome.shrunk)
    raise exc


def _evidence(ctx: CaseContext, found: Divergence, *, final: bool) -> int | None:
    """Return the trace index where the reported example diverged.

    Hypothesis' final replay recorded into the case's trace; otherwise the example's own trace
    (kept with the divergence) is copied in.
    """
    if final and found.trace_index is not None:
        return found.trace_index
    if not final and found.entries:
        first = _copy(ctx, found.entries, "the frames of the reported example follow")
        if found.trace_index is not None:
            return first + 1 + found.trace_index
    return len(ctx.trace) - 1 if len(ctx.trace) else None


def _copy(ctx: CaseContext, entries: tuple[TraceEntry, ...], title: str) -> int:
    """Copy an example's trace into the case's, after a note; return the note's index."""
    first = ctx.trace.note(f"{title} (times are those of the copy)")
    for entry in entries:
        ctx.trace.add(entry.conn, entry.direction, entry.tag, entry.text)
    return first


def _steps(lines: tuple[str, ...]) -> str:
    return "\n".join(f"  {n}. {line}" for n, line in enumerate(lines, 1)) or "  (none)"
