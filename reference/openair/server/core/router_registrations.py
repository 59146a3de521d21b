"""Registrations on the router's side: AIR.Subscribe, phases in force, the trigger index (spec 8).

A part of `Router` (`router_state` says how the parts fit); sans-I/O: time comes in as `now_ns`.
"""

from __future__ import annotations

from openair.protocol.content import ANY_WHITEBOARD, Phase, Registration
from openair.protocol.errors import OpenAIRError
from openair.protocol.matching import ascii_fold
from openair.protocol.message import Message
from openair.protocol.registration import parse_registration
from openair.protocol.wakeup import build_wakeup
from openair.server.core import commands as cmd
from openair.server.core.config import DEFAULT_WB_PRIORITY
from openair.server.core.contexts import PHASE_CHANGE, context_of
from openair.server.core.outcome import Delivery, Outcome
from openair.server.core.router_state import IndexedTriggers, RouterState
from openair.server.core.whiteboard import Whiteboard, derive

__all__ = ["Registrations"]

_PHASE_SENDER = "ContextsAndPhases"  # the sender of phase updates (OA-WAKE-9)


class Registrations(RouterState):
    """Registrations in force, phase updates and the trigger index (a part of `Router`)."""

    def registration(self, name: str) -> Registration | None:
        """Return the registration in force for `name`: subscribed, else configured."""
        return self._subscribed.get(name) or self._configured.get(name)

    def _subscribe(self, board: Whiteboard, msg: Message, now_ns: int) -> Outcome:
        """Replace the sender's whole registration (OA-REG-1, OA-REG-7, OA-REG-8)."""
        try:
            reg = parse_registration(msg.sender, msg.content, max_triggers=self.limits.max_triggers)
        except OpenAIRError as err:  # OA-REG-8: the previous registration stays in force
            return Outcome(replies=(self._error(msg, err, board.name, now_ns),))
        self._subscribed[msg.sender] = reg
        if self._contexts is not None:
            self._contexts.forget(msg.sender)  # OA-REG-17: a new registration starts afresh
        self._reindex(msg.sender)
        ack = cmd.reply(msg, "RECEIVE_ACCEPT", sender=board.name, now_ns=now_ns)
        return Outcome(replies=(ack,), deliveries=self._phase_update(msg.sender, now_ns))

    def _phase_update(self, name: str, now_ns: int) -> tuple[Delivery, ...]:
        """Tell a bound module its phase in force after a registration (OA-WAKE-9)."""
        if name not in self._modules:
            return ()
        reg = self.registration(name)
        update = build_wakeup(
            stored=None,
            whiteboard=_PHASE_SENDER,
            module=name,
            phase=self._phase_in_force(name, reg),
        )
        self._module_counters(name).queued += 1
        message = derive(update, posted=cmd.ms_time(now_ns))
        return (
            Delivery(
                module=name,
                message=message,
                due_ns=now_ns,
                priority=message.effective_priority,
                wb_priority=DEFAULT_WB_PRIORITY,
            ),
        )

    def _phase_in_force(self, name: str, reg: Registration | None) -> Phase | None:
        """Return the phase in force: by contexts (OA-REG-14), else Ready's first (OA-REG-10)."""
        if self._contexts is not None:
            return self._contexts.phase(name, reg)
        return reg.active_phase if reg is not None else None

    def _context_post(
        self, board: Whiteboard, stored: Message, now_ns: int
    ) -> tuple[Delivery, ...]:
        """Apply a context or phase change, then decide the post's wakeups (OA-REG-13..18)."""
        assert self._contexts is not None
        if stored.type == PHASE_CHANGE:  # OA-REG-17: the poster's own phase advances
            reg = self.registration(stored.sender)
            self._contexts.advance(stored.sender, reg)
            names = [stored.sender] if reg is not None else []
        else:
            context = context_of(stored.type)
            changed = context is not None and self._contexts.activate(context)
            names = list(self._triggers) if changed else []
        updates: list[Delivery] = []
        for name in names:
            old = self._triggers.get(name)
            self._reindex(name)
            new = self._triggers.get(name)
            if (old.phase if old else None) is not (new.phase if new else None):
                updates.extend(self._phase_update(name, now_ns))  # OA-REG-15
        return (*updates, *self._decide(board, stored, now_ns))

    def _reindex(self, name: str) -> None:
        """Put the triggers of `name`'s registration in force into the index (OA-REG-1)."""
        old = self._triggers.pop(name, None)
        self._index_changes += 1  # the route cache starts again (router_routes)
        if old is not None:
            for i, (pattern, _, _) in enumerate(old.entries):
                self._index.remove(pattern, (name, i))
        reg = self.registration(name)
        self.streams.set_registration(name, reg)  # OA-STREAM-14: inputstream sources
        if reg is None:
            self._sessions.set_registration(name, None)
            return
        phase = self._phase_in_force(name, reg)
        entries = tuple(
            (t.pattern, _folded_board(t.whiteboard), t.after_ms)
            for t in (phase.triggers if phase is not None else ())
        )  # OA-REG-10, OA-REG-14: the triggers of the phase in force
        for i, (pattern, _, _) in enumerate(entries):
            self._index.add(pattern, (name, i))
        self._triggers[name] = IndexedTriggers(
            registration=reg,
            entries=entries,
            allow_self=reg.allow_self_triggering,
            phase=phase,
        )
        self._sessions.set_registration(name, reg)


def _folded_board(whiteboard: str) -> str:
    """Fold a trigger's `from` for comparison; any / * / empty mean every board (OA-TRIG-2)."""
    folded = ascii_fold(whiteboard.strip())
    return ANY_WHITEBOARD if folded in ("", "any", "*") else folded
