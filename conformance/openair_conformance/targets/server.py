"""The server target: an OpenAIR server over TCP (`openair conform HOST:PORT`).

`RunOptions` says what to run against which server and how; `ServerTarget` probes the server
(round-trip time, capabilities), runs each case in a `CaseContext` of its own within a budget,
asks after a case that did not pass whether the server still answers a PING, and restarts it
with `--restart-cmd` when asked to.
"""

from __future__ import annotations

import asyncio
import math
import secrets
import shlex
import ssl
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from openair_conformance.harness.context import GRACE_FACTOR, CaseContext, deadline_for
from openair_conformance.harness.liveness import Restarter, alive
from openair_conformance.harness.probe import probe
from openair_conformance.model import Fail, NotApplicable, ServerInfo, Verdict
from openair_conformance.registry import RegisteredCase
from openair_conformance.schedule import DEATH_ACTIONS, ORDERS, EngineError, Schedule
from openair_conformance.targets import Started, Watch
from openair_conformance.verdicts import DEFAULT_FAIL_ON, Attempt

__all__ = ["DEFAULT_PORT", "DEFAULT_STREAM", "RunOptions", "ServerTarget", "parse_target"]

DEFAULT_PORT = 10000
DEFAULT_STREAM = "Stream1"
# A case that runs longer than this many deadlines (and at least _MIN_BUDGET s) is stopped and
# judged ERROR: every wait in the harness is bounded, so only a harness bug gets there.
_BUDGET_DEADLINES = 60
_MIN_BUDGET = 60.0
#: Fuzzing examples against a slow target (see `ServerTarget.fuzz_examples`).
_FUZZ_DEFAULT = 25
_FUZZ_FAST_RTT = 0.05
_FUZZ_MIN_EXAMPLES = 5


@dataclass(frozen=True, slots=True, kw_only=True)
class RunOptions:
    """What to run, against what, and how."""

    target: tuple[str, int]
    case_globs: tuple[str, ...] = ()
    sections: tuple[str, ...] = ()
    jobs: int = 1
    timeout_scale: float = 1.0
    expectations: Path | str | None = None
    fail_on: frozenset[Verdict] = DEFAULT_FAIL_ON
    verbose: bool = False
    fuzz_examples: int | None = None
    replay: str | None = None
    #: The stream the stream cases use (spec section 11; Stream1 is offered without a
    #: configuration, OA-STREAM-15).
    stream: str = DEFAULT_STREAM
    #: Module names and secrets the secure-mode cases prove (spec 14.3; `--auth-secrets`).
    auth_secrets: Mapping[str, str] = field(default_factory=dict, repr=False)  # never shown
    #: TLS towards the target (spec 14.3, OA-AUTH-10; `--tls-ca`); None: plain TCP.
    tls: ssl.SSLContext | None = field(default=None, repr=False)
    run_id: str = field(default_factory=lambda: secrets.token_hex(2))
    probe_timeout: float = 10.0
    #: `registry` (ID order) or `random` (shuffled with `seed`; a seed is drawn when None).
    order: str = "registry"
    seed: int | None = None
    #: When the target stops answering: `stop`, `continue`, or `restart` (runs `restart_cmd`).
    on_target_death: str = "stop"
    restart_cmd: str = ""
    restart_timeout: float = 60.0

    def __post_init__(self) -> None:
        if self.jobs < 1:
            raise EngineError("jobs must be at least 1")
        if not (self.timeout_scale > 0 and math.isfinite(self.timeout_scale)):
            raise EngineError("timeout scale must be a positive number")
        if not self.run_id.isalnum():
            raise EngineError("run id must be letters and digits")
        if not self.stream or any(ch.isspace() or ch == ";" for ch in self.stream):
            raise EngineError("stream name must be non-empty, without white space or ';'")
        if self.order not in ORDERS:
            raise EngineError(f"order must be one of {', '.join(ORDERS)}")
        if self.order == "random" and self.seed is None:  # drawn, and reported to replay it
            object.__setattr__(self, "seed", secrets.randbelow(1 << 31))
        if self.on_target_death not in DEATH_ACTIONS:
            raise EngineError(f"on-target-death must be one of {', '.join(DEATH_ACTIONS)}")
        if (self.on_target_death == "restart") != bool(self.restart_cmd.strip()):
            raise EngineError("restart-cmd needs a command, and a command needs restart-cmd")

    @property
    def target_text(self) -> str:
        """HOST:PORT (IPv6 hosts in brackets)."""
        host, port = self.target
        return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"

    @property
    def schedule(self) -> Schedule:
        """The engine's part of these options."""
        return Schedule(
            jobs=self.jobs, order=self.order, seed=self.seed, on_target_death=self.on_target_death
        )


def parse_target(text: str) -> tuple[str, int]:
    """Parse `HOST[:PORT]` or `[V6]:PORT`; the port defaults to 10000. ValueError if bad."""
    text = text.strip()
    if text.startswith("["):
        host, _, rest = text[1:].partition("]")
        port_text = rest[1:] if rest.startswith(":") else ""
        if rest and not rest.startswith(":"):
            raise ValueError(f"bad target {text!r}")
    elif text.count(":") == 1:
        host, port_text = text.split(":")
    else:
        host, port_text = text, ""
    if not host:
        raise ValueError(f"bad target {text!r}: no host")
    try:
        port = int(port_text) if port_text else DEFAULT_PORT
    except ValueError as exc:
        raise ValueError(f"bad target {text!r}: port is not a number") from exc
    if not 0 < port < 65536:
        raise ValueError(f"bad target {text!r}: port out of range")
    return host, port


class ServerTarget:
    """A server over TCP: probed once, then each case in a fresh `CaseContext`."""

    def __init__(self, options: RunOptions) -> None:
        self.options = options
        self.label = options.target_text
        self.server = ServerInfo(legacy=False)
        self.restarter: Restarter | None = None
        if options.on_target_death == "restart":
            self.restarter = Restarter(options.restart_cmd, timeout=options.restart_timeout)

    @property
    def rtt(self) -> float:
        return self.server.rtt_ms / 1000.0

    @property
    def deadline(self) -> float:
        return deadline_for(self.rtt, self.options.timeout_scale)

    @property
    def fuzz_examples(self) -> int | None:
        """--fuzz-examples; else, for a slow target, fewer than the fuzzing cases' default.

        A fuzzing example is a dozen round trips: at 0.3 s each, the default 25 examples took
        over two minutes of a run that must fit in five (issue #16). Above `_FUZZ_FAST_RTT` the
        count shrinks with the round-trip time, to no fewer than `_FUZZ_MIN_EXAMPLES`.
        """
        if self.options.fuzz_examples is not None or self.rtt <= _FUZZ_FAST_RTT:
            return self.options.fuzz_examples
        return max(_FUZZ_MIN_EXAMPLES, int(_FUZZ_DEFAULT * _FUZZ_FAST_RTT / self.rtt))

    async def start(self) -> Started:
        self.server = await probe(*self.options.target, timeout=self.options.probe_timeout)
        return Started(
            server=self.server,
            options=_options_record(self.options, self.server),
            latencies=(("rtt_ms", self.server.rtt_ms),),
        )

    async def attempt(self, case: RegisteredCase, watch: Watch) -> Attempt:
        info = case.info
        ctx = CaseContext(
            case=info,
            target=self.options.target,
            rtt=self.rtt,
            timeout_scale=self.options.timeout_scale,
            server=self.server,
            run_id=self.options.run_id,
            fuzz_examples=self.fuzz_examples,
            replay=self.options.replay,
            stream=self.options.stream,
            secrets=self.options.auth_secrets,
        )
        watch(ctx.trace.origin, lambda: ctx.trace.entries)
        outcome = await self._execute(case, ctx)
        divergence = None
        if isinstance(outcome, Fail):
            divergence = outcome.divergence
            if divergence is None and len(ctx.trace):
                divergence = len(ctx.trace) - 1
        return Attempt(
            outcome=outcome,
            trace=ctx.trace.entries,
            divergence=divergence,
            measurements=ctx.measurements,
            repro=self.repro(info.id, ctx.repro_args),
            vacuous_reason=ctx.vacuous_reason or "",
        )

    async def _execute(self, case: RegisteredCase, ctx: CaseContext) -> BaseException | None:
        missing = sorted(case.info.needs - set(self.server.capabilities))
        if missing:
            return NotApplicable(f"the server does not advertise {', '.join(missing)}")
        budget = max(_MIN_BUDGET, _BUDGET_DEADLINES * ctx.deadline)
        outcome: BaseException | None = None
        try:
            await asyncio.wait_for(case.fn(ctx), budget)
        except TimeoutError:
            outcome = RuntimeError(f"the case did not finish within its {budget:.0f} s budget")
        except Exception as exc:
            outcome = exc
        finally:
            try:
                await ctx.aclose()
            except Exception as exc:
                ctx.note(f"closing the case's connections failed: {exc!r}")
        return outcome

    def repro(self, case_id: str, extra: tuple[str, ...] | list[str]) -> str:
        words = ["openair", "conform", self.options.target_text, "--case", case_id]
        if self.options.timeout_scale != 1.0:
            words += ["--timeout-scale", f"{self.options.timeout_scale:g}"]
        if self.options.stream != DEFAULT_STREAM:
            words += ["--stream", self.options.stream]
        return shlex.join([*words, *extra])

    async def alive(self) -> str | None:
        """One PING; the wait is four deadlines (twice the fail threshold), so that a slow
        target is not taken for a dead one."""
        host, port = self.options.target
        return await alive(host, port, timeout=self.deadline * 4)

    async def restart(self) -> str | None:
        assert self.restarter is not None
        host, port = self.options.target
        return await self.restarter.restart(host, port, probe_timeout=self.deadline)

    async def close(self) -> None:
        return None


def _options_record(options: RunOptions, server: ServerInfo) -> dict[str, str]:
    deadline = deadline_for(server.rtt_ms / 1000.0, options.timeout_scale)
    record = {
        "target": options.target_text,
        "jobs": str(options.jobs),
        "timeout_scale": f"{options.timeout_scale:g}",
        "deadline_s": f"{deadline:.3f}",
        "grace_s": f"{GRACE_FACTOR * deadline:.3f}",
        "run_id": options.run_id,
        "fail_on": ",".join(sorted(v.value for v in options.fail_on)),
    }
    optional = {
        "cases": " ".join(options.case_globs),
        "sections": " ".join(options.sections),
        "expectations": "" if options.expectations is None else str(options.expectations),
        "fuzz_examples": "" if options.fuzz_examples is None else str(options.fuzz_examples),
        "replay": options.replay or "",
        "stream": "" if options.stream == DEFAULT_STREAM else options.stream,
    }
    record.update({k: v for k, v in optional.items() if v})
    if options.order != "registry":
        record["order"] = options.order
        record["seed"] = str(options.seed)
    if options.on_target_death != "stop":
        record["on_target_death"] = options.on_target_death
    if options.restart_cmd:
        record["restart_cmd"] = options.restart_cmd
    return record
