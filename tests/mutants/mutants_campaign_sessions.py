"""Mutants of issue #15 from the cosmic-ray survivors of the session modules (core/sessions.py,
protocol/registration.py).

Each was a survivor an implementer could plausibly write: a BIND again on the module's own
primary connection taken for a takeover, which posts Psyclone.Module.Restored (OA-SESS-35;
SESS-045), a lost module whose callback connection is left open (OA-SESS-15; SESS-046), a
callback connection that ended but stays the module's (or the one its name gets at BIND), so
each delivery fails and is abandoned instead of waiting for the next callback connection
(OA-SESS-5, OA-DELIV-8; SESS-047), and a registration refused for a phase's `priority`
attribute (OA-REG-4; REG-015).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pytest
from lxml import etree
from mutants_core import Fn, mutant, wrap

from openair.protocol import registration
from openair.protocol.errors import RegistrationInvalidError
from openair.protocol.message import Message
from openair.server.core.sessions import Bound, ConnId, Sessions


@mutant(
    "rebind-posts-restored",
    "a BIND again on the module's own primary connection is reported as a takeover: "
    "Psyclone.Module.Restored is posted",
    "OA-SESS-35",
    "OA-SESS-6",
    cases=("SESS-045",),
)
def _rebind_posts_restored(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def bind(self: Sessions, conn: ConnId, msg: Message, reg: Any) -> Bound:
            bound_before = msg.sender in self.modules
            bound: Bound = original(self, conn, msg, reg)
            return replace(bound, took_over=True) if bound_before else bound

        return bind

    wrap(mp, Sessions, "bind", make)


@mutant(
    "lost-keeps-callback",
    "when a module's primary connection closes, its callback connection is left open",
    "OA-SESS-15",
    cases=("SESS-046",),
)
def _lost_keeps_callback(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def closed(self: Sessions, conn: ConnId) -> tuple[list[str], tuple[ConnId, ...]]:
            names, _ = original(self, conn)
            return names, ()  # the callbacks are not closed

        return closed

    wrap(mp, Sessions, "closed", make)


@mutant(
    "ended-callback-kept",
    "a callback connection that ended stays the module's (or the one its name gets at BIND), so "
    "deliveries to a module without a listening port fail and are abandoned instead of waiting",
    "OA-SESS-5",
    "OA-DELIV-8",
    cases=("SESS-047",),
)
def _ended_callback_kept(mp: pytest.MonkeyPatch) -> None:
    def _drop_callback(self: Sessions, conn: ConnId) -> None:
        self._callbacks.pop(conn, None)  # the module's callback and a pending one stay as they were

    mp.setattr(Sessions, "_drop_callback", _drop_callback)


@mutant(
    "phase-priority-refused",
    "an AIR.Subscribe whose phase carries a priority attribute is refused REGISTRATION_INVALID",
    "OA-REG-4",
    cases=("REG-015",),
)
def _phase_priority_refused(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def priority(self: Any, el: etree._Element) -> float:
            if self.strict and el.get("priority") is not None:
                raise RegistrationInvalidError("a phase has no priority attribute")
            return float(original(self, el))

        return priority

    wrap(mp, registration._Reader, "priority", make)
