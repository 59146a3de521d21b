"""Mutants of issue #15 from the cosmic-ray survivors of the system components' commands
(core/router_commands.py, core/router_registrations.py).

Each was a survivor an implementer could plausibly write: a STATUS whose `Created` is the time
of the reply rather than when the server started (OA-SESS-25; SESS-019), a RESOLVE_SUCCESS whose
`<tcplocation>` is written as escaped text instead of XML content (OA-SESS-8, OA-MSG-12; SESS-060),
and no phase update for a module that had no phase in force when a context brings one into
force, the "changed" test looking only at modules that had a phase (OA-REG-15; CTX-003, which
runs alone so that no other case's context change sends the update it waits for).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.message import Message
from openair.server.core import commands
from openair.server.core.outcome import Delivery
from openair.server.core.router import Router
from openair.server.core.whiteboard import Whiteboard

_PHASE_SENDER = "ContextsAndPhases"


@mutant(
    "status-created-now",
    "STATUS_SUCCESS gives the time of the reply as Created, not when the server started",
    "OA-SESS-25",
    cases=("SESS-019",),
)
def _status_created_now(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def status_reply(req: Message, **kwargs: Any) -> Message:
            kwargs["started_ns"] = kwargs["now_ns"]
            reply: Message = original(req, **kwargs)
            return reply

        return status_reply

    wrap(mp, commands, "status_reply", make)


@mutant(
    "resolve-location-as-text",
    "RESOLVE_SUCCESS writes its <tcplocation> as escaped text (no language xml)",
    "OA-SESS-8",
    "OA-MSG-12",
    cases=("SESS-060",),
)
def _resolve_location_as_text(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def reply(req: Message, type_: str, **kwargs: Any) -> Message:
            if type_ == "RESOLVE_SUCCESS":
                kwargs["xml"] = False
            answer: Message = original(req, type_, **kwargs)
            return answer

        return reply

    wrap(mp, commands, "reply", make)


@mutant(
    "ctx-no-update-into-phase",
    "a module without a phase in force gets no phase update when a context brings one into force",
    "OA-REG-15",
    cases=("CTX-003",),
)
def _no_update_into_phase(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def context_post(
            self: Router, board: Whiteboard, stored: Message, now_ns: int
        ) -> tuple[Delivery, ...]:
            unphased = {name for name, t in self._triggers.items() if t.phase is None}
            out: tuple[Delivery, ...] = original(self, board, stored, now_ns)
            return tuple(
                d for d in out if d.module not in unphased or d.message.sender != _PHASE_SENDER
            )

        return context_post

    wrap(mp, Router, "_context_post", make)
