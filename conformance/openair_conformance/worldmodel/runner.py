"""Run the world-model cases on the one engine: `WorldModelTarget` and `run_cases`.

`WorldModelTarget` joins the whiteboard as a peer module (`Peer`) once, then runs each case
with a `Ctx` of its own (a unique prefix, the time now); the engine judges the outcomes with
the verdicts of every other mode and feeds the same reporters (`openair conform-worldmodel`).
`run_cases` is the plain-values view of such a run, for callers that want no reporter.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Sequence
from dataclasses import dataclass

from openair_conformance.engine import run_target
from openair_conformance.model import Reporter, RunSummary, ServerInfo, Verdict
from openair_conformance.schedule import NoCasesSelected
from openair_conformance.targets import Started, Watch
from openair_conformance.verdicts import Attempt
from openair_conformance.worldmodel.cases import CASES, Ctx, WmCase
from openair_conformance.worldmodel.peer import Peer

__all__ = ["WmResult", "WorldModelTarget", "run_cases", "run_worldmodel", "selected_cases"]

#: The words of `WmResult.verdict` for the engine's verdicts (anything else is `error`).
_WORDS = {Verdict.PASS: "passed", Verdict.FAIL: "failed"}


@dataclass(frozen=True, slots=True, kw_only=True)
class WmResult:
    """One case's verdict: `passed`, `failed` or `error`, with the reason."""

    case: WmCase
    verdict: str
    detail: str = ""


class WorldModelTarget:
    """A world-model module, reached through the whiteboard it works on."""

    def __init__(
        self, host: str, port: int, module: str, *, whiteboard: str = "WB1", bound: float = 10.0
    ) -> None:
        self.host, self.port, self.module = host, port, module
        self.whiteboard, self.bound = whiteboard, bound
        self.prefix = f"C{uuid.uuid4().hex[:8]}"
        self.label = f"{module}@{host}:{port}/{whiteboard}"
        self.peer: Peer | None = None

    async def start(self) -> Started:
        """Join the whiteboard (OSError when the server cannot be reached)."""
        peer = Peer(f"WMConform{self.prefix}", self.host, self.port, self.whiteboard, self.bound)
        await peer.start()
        self.peer = peer
        options = {
            "mode": "worldmodel",
            "module": self.module,
            "whiteboard": self.whiteboard,
            "bound_s": f"{self.bound:g}",
        }
        return Started(
            server=ServerInfo(legacy=False, server=self.module, protocol="worldmodel"),
            options=options,
        )

    async def attempt(self, case: WmCase, watch: Watch) -> Attempt:
        assert self.peer is not None, "start() first"
        ctx = Ctx(
            peer=self.peer,
            module=self.module,
            prefix=f"{self.prefix}{case.id.replace('-', '')}",
            now_us=time.time_ns() // 1000,
        )
        try:
            await case.fn(ctx)
        except Exception as exc:  # CaseFailure is a Fail; anything else is an error
            return Attempt(outcome=exc, repro=self.repro(case.id))
        return Attempt(outcome=None, repro=self.repro(case.id))

    def repro(self, case_id: str) -> str:
        return (
            f"openair conform-worldmodel {self.host}:{self.port} --module {self.module} "
            f"--whiteboard {self.whiteboard} --case {case_id}"
        )

    async def alive(self) -> None:
        return None

    async def restart(self) -> None:
        return None

    async def close(self) -> None:
        if self.peer is not None:
            await self.peer.close()


def selected_cases(prefix: str = "") -> list[WmCase]:
    """The cases whose ID starts with `prefix` (every case for "")."""
    return [item for item in CASES if item.id.startswith(prefix)]


async def run_worldmodel(
    target: WorldModelTarget, reporters: Sequence[Reporter] = (), *, prefix: str = ""
) -> RunSummary:
    """Run the cases whose ID starts with `prefix`, one at a time, against `target`."""
    selected = selected_cases(prefix)
    if not selected:
        raise NoCasesSelected(f"no world-model case starts with {prefix!r}")
    return await run_target(target, selected, reporters)


async def run_cases(
    host: str,
    port: int,
    module: str,
    *,
    whiteboard: str = "WB1",
    bound: float = 10.0,
    select: str = "",
) -> list[WmResult]:
    """Run every case (or those whose ID starts with `select`), each wait bounded by `bound` s."""
    if not selected_cases(select):
        return []
    target = WorldModelTarget(host, port, module, whiteboard=whiteboard, bound=bound)
    summary = await run_worldmodel(target, prefix=select)
    by_id = {item.id: item for item in CASES}
    return [
        WmResult(case=by_id[r.info.id], verdict=_WORDS.get(r.verdict, "error"), detail=r.message)
        for r in summary.results
    ]
