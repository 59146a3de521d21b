"""Mutants of issue #15 from the cosmic-ray survivors of the routing modules (core/retrieve.py,
core/router.py).

Each was a survivor an implementer could plausibly write: a retrieve reply whose size is judged
by its results' contents only, so a reply whose envelopes take it past max-frame-xml is sent
anyway (OA-RET-15; RET-013 posts two contents 256 bytes short of the limit), no bound on the
bytes held, so a post is acknowledged however much is held (OA-LIM-14; LIM-014 at
max-held-bytes 262 144), and the counters of a gone module kept for ever (OA-LIM-15; LIM-015 at
module-retention-ms 200).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import mutant

from openair.server.core import retrieve
from openair.server.core.router import Router


@mutant(
    "retrieve-envelope-uncounted",
    "a retrieve reply is measured by its results' contents only: a reply whose envelopes take "
    "its XML past max-frame-xml is sent",
    "OA-RET-15",
)
def _retrieve_envelope_uncounted(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(retrieve, "_ENVELOPE_ALLOWANCE", -(1 << 40))  # the collection check never fires


@mutant(
    "no-held-bound",
    "a post is never refused for the bytes the server holds (max-held-bytes advertised, not "
    "enforced)",
    "OA-LIM-14",
    limits={"max_held_bytes": 262_144},
)
def _no_held_bound(mp: pytest.MonkeyPatch) -> None:
    def _over_budget(self: Router, *args: Any, **kwargs: Any) -> None:
        return None

    mp.setattr(Router, "_over_budget", _over_budget)


@mutant(
    "gone-kept-forever",
    "the counters of a module that is no longer bound are never forgotten",
    "OA-LIM-15",
    limits={"module_retention_ms": 200},
)
def _gone_kept_forever(mp: pytest.MonkeyPatch) -> None:
    def forget_gone(self: Router, *args: Any, **kwargs: Any) -> int:
        return 0

    mp.setattr(Router, "forget_gone", forget_gone)
