"""What the conformance engine runs cases against: the `Target` interface and its three kinds.

The engine (`engine.run_target`) knows nothing of sockets, shims or world models: it selects,
orders and schedules cases, asks the target to run each one (`Target.attempt`), judges the
outcome with the one verdict model (`verdicts`), and feeds the same events to the same
reporters. A target says what it is at the start (`Target.start` → `Started`: the `ServerInfo`
the reporters show, the options record, the latencies measured before any case), runs one case
at a time or several at once, and says whether it is still alive after a case that did not
pass (`Target.alive`; `restart` brings it back for `--on-target-death restart`).

- `targets.server.ServerTarget`: a server over TCP (`openair conform HOST:PORT`);
- `clientmode.engine.ShimTarget`: a client library through its shim (`openair conform-client`);
- `worldmodel.runner.WorldModelTarget`: a world-model module through a whiteboard
  (`openair conform-worldmodel`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol, TypeAlias, TypeVar

from openair_conformance.model import CaseInfo, ServerInfo, TraceEntry
from openair_conformance.verdicts import Attempt

__all__ = ["Attempt", "Case", "Started", "Target", "Watch"]

#: `watch(origin, entries)`: a running case's trace (see `Target.attempt`).
Watch: TypeAlias = Callable[[float, Callable[[], Sequence[TraceEntry]]], None]


class Case(Protocol):
    """Anything the engine can schedule: it has a `CaseInfo`."""

    @property
    def info(self) -> CaseInfo: ...


C_contra = TypeVar("C_contra", bound=Case, contravariant=True)


@dataclass(frozen=True, slots=True, kw_only=True)
class Started:
    """What a target reports once it is reachable, before the first case."""

    server: ServerInfo
    #: Shown by the reporters as the run's options (`RunStarted.options`).
    options: dict[str, str] = field(default_factory=dict)
    #: Measured before any case (round-trip time, the shim's start-up), first in the summary.
    latencies: tuple[tuple[str, float], ...] = ()


class Target(Protocol[C_contra]):
    """A thing under test, as the engine sees it."""

    #: How the reporters name it (`RunStarted.target`): HOST:PORT, the shim command, …
    label: str

    async def start(self) -> Started:
        """Reach the target (probe it); raise before any event when it cannot be used."""
        ...

    async def attempt(self, case: C_contra, watch: Watch) -> Attempt:
        """Run one case once and return its outcome and evidence (never raises).

        A target whose cases keep a trace hands it to `watch` as soon as the case starts (when
        it began, and how to read its entries), so that the engine can name the case that
        sent the first frame nothing answered when the target dies mid-run.
        """
        ...

    async def alive(self) -> str | None:
        """After a case that did not pass: why the target looks dead, or None."""
        ...

    async def restart(self) -> str | None:
        """Bring a dead target back; return why that failed, or None."""
        ...

    async def close(self) -> None:
        """Release what `start` acquired (called once, when `start` succeeded)."""
        ...
