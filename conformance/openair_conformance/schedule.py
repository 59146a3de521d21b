"""How a run schedules its cases, whatever the target: jobs, order, and what a death does.

`Schedule` is the part of a run's options the engine itself acts on; each target's options
(`targets.server.RunOptions`, `clientmode.engine.ClientRunOptions`, the world-model checker's)
build one. `EngineError` is what a run that cannot start raises.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DEATH_ACTIONS", "ORDERS", "EngineError", "NoCasesSelected", "Schedule"]

#: What `--on-target-death` may say (`restart` needs a restart command).
DEATH_ACTIONS = ("stop", "continue", "restart")
#: The orders cases may be started in (`--order`).
ORDERS = ("registry", "random")


class EngineError(Exception):
    """The run cannot start (bad options, nothing selected)."""


class NoCasesSelected(EngineError):
    """The --case / --section filters selected no case."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Schedule:
    """`jobs` non-serial cases at a time, in `order` (`random`: shuffled with `seed`)."""

    jobs: int = 1
    order: str = "registry"
    seed: int | None = None
    on_target_death: str = "stop"

    def __post_init__(self) -> None:
        if self.jobs < 1:
            raise EngineError("jobs must be at least 1")
        if self.order not in ORDERS:
            raise EngineError(f"order must be one of {', '.join(ORDERS)}")
        if self.on_target_death not in DEATH_ACTIONS:
            raise EngineError(f"on-target-death must be one of {', '.join(DEATH_ACTIONS)}")
