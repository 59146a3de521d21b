"""Run the world-model cases against one module on a whiteboard; results as plain values."""

from __future__ import annotations

import time
import uuid
from dataclasses import dataclass

from openair_conformance.worldmodel.cases import CASES, Ctx, WmCase
from openair_conformance.worldmodel.peer import CaseFailure, Peer


@dataclass(frozen=True, slots=True, kw_only=True)
class WmResult:
    """One case's verdict: `passed`, `failed` or `error`, with the reason."""

    case: WmCase
    verdict: str
    detail: str = ""


async def run_cases(
    host: str,
    port: int,
    module: str,
    *,
    whiteboard: str = "WB1",
    bound: float = 10.0,
    select: str = "",
) -> list[WmResult]:
    """Run every case (or those whose ID starts with `select`), each bounded by `bound` s."""
    prefix = f"C{uuid.uuid4().hex[:8]}"
    peer = Peer(f"WMConform{prefix}", host, port, whiteboard, bound)
    await peer.start()
    results = []
    try:
        for item in CASES:
            if select and not item.id.startswith(select):
                continue
            ctx = Ctx(
                peer=peer,
                module=module,
                prefix=f"{prefix}{item.id.replace('-', '')}",
                now_us=time.time_ns() // 1000,
            )
            try:
                await item.fn(ctx)
                results.append(WmResult(case=item, verdict="passed"))
            except CaseFailure as exc:
                results.append(WmResult(case=item, verdict="failed", detail=str(exc)))
            except Exception as exc:  # a case that cannot run is an error, not a failure
                results.append(WmResult(case=item, verdict="error", detail=repr(exc)))
    finally:
        await peer.close()
    return results
