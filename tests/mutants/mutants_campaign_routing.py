"""Mutants of issue #15 from the cosmic-ray survivors of the routing modules (core/retrieve.py,
core/router.py).

Each was a survivor an implementer could plausibly write: a retrieve reply whose size is judged
by its results' contents only, so a reply whose envelopes take it past max-frame-xml is sent
anyway (OA-RET-15; RET-013 posts two contents 256 bytes short of the limit), no bound on the
bytes held, so a post is acknowledged however much is held (OA-LIM-14; LIM-014 at
max-held-bytes 262 144), and the counters of a gone module kept for ever (OA-LIM-15; LIM-015 at
module-retention-ms 200). The 2026-11-29 campaign added: queued deliveries left out of the bytes
held (OA-LIM-14; LIM-016 queues wakeups that retrieve an eighth of max-held-bytes each), the
whole history of the whiteboard posted to counted as freed (OA-LIM-14; LIM-014), and a
timetolive of 0 read as "expire at once" instead of "no limit" (OA-DELIV-14; QOS-003).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.message import Message
from openair.server.aio.dispatcher import Dispatcher
from openair.server.core import retrieve
from openair.server.core.router import Router
from openair.server.core.whiteboard import Whiteboard


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


@mutant(
    "queued-bytes-uncounted",
    "the bytes of queued deliveries are left out of max-held-bytes: a post is refused only for "
    "the stored copies",
    "OA-LIM-14",
    limits={"max_held_bytes": 262_144},
)
def _queued_bytes_uncounted(mp: pytest.MonkeyPatch) -> None:
    def queued_bytes(self: Dispatcher) -> int:
        return 0

    mp.setattr(Dispatcher, "queued_bytes", queued_bytes)


@mutant(
    "held-credit-whole-history",
    "what storing a post evicts is counted as the whole history of its whiteboard, so the "
    "copies stored there never count toward max-held-bytes",
    "OA-LIM-14",
    limits={"max_held_bytes": 262_144},
)
def _held_credit_whole_history(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def over_budget(self: Router, board: Whiteboard, msg: Message) -> Any:
            kept = board.bytes
            board.bytes = 0  # neither held nor freed: as if all of it were evicted
            try:
                return original(self, board, msg)
            finally:
                board.bytes = kept

        return over_budget

    wrap(mp, Router, "_over_budget", make)


@mutant(
    "ttl-zero-expires",
    "a timetolive of 0 expires a delivery at the message's receivedTime instead of setting no "
    "limit",
    "OA-DELIV-14",
)
def _ttl_zero_expires(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def expiry(self: Router, msg: Message, received_ns: int) -> int:
            if self._qos and msg.timetolive == 0:
                return received_ns
            return int(original(self, msg, received_ns))

        return expiry

    wrap(mp, Router, "_expiry", make)
