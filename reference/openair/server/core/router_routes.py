"""The wakeups of a stored post (spec 8.6): whom it wakes (OA-WAKE-5/6) and what each gets.

Whom it wakes is kept in a route cache (issue #20).

Deciding it reads the pattern index, each module's triggers and the bound names. Between two
registrations nothing of that changes, and a lab's posts repeat a few types from a few
senders, so the answer is kept per (whiteboard, type, sender, priority) — the priority for
alarm triggers (OA-TRIG-5) — and thrown away whenever the index changes (`_reindex`) or a
name is bound or unbound (`Sessions.generation`). `cc` (OA-CC-1) is added to each answer, never
cached.
"""

from __future__ import annotations

from collections.abc import Sequence

from openair.protocol.content import Phase, Registration
from openair.protocol.matching import ascii_fold
from openair.protocol.message import Message
from openair.protocol.wakeup import attach_wakeup, fit_attachments, phase_spec_xml
from openair.server.core import commands as cmd
from openair.server.core.outcome import Delivery
from openair.server.core.retrieve import registration_results
from openair.server.core.router_state import RouterState, urgent_enough
from openair.server.core.wakeups import LARGE_WAKEUP, TriggerXml, WakeupParts
from openair.server.core.whiteboard import Whiteboard

__all__ = ["ROUTE_CACHE_SIZE", "Routes", "Woken"]

#: (after ms, lasttrigger) per module to wake.
Woken = dict[str, tuple[int, str]]
#: Answers kept at most; the cache starts again when full.
ROUTE_CACHE_SIZE = 4096
_Key = tuple[str, str, str, float | None]
_NS_PER_MS = 1_000_000
_PHASE_CACHE_SIZE = 256  # PhaseSpec texts kept per registration (one per lasttrigger)


class Routes(RouterState):
    """The router's part that decides whom a post wakes, and the wakeup each of them gets."""

    _routes: dict[_Key, Woken]
    _routes_at: tuple[int, int]  # (the router's index changes, the sessions' generation)

    def _woken(self, board: Whiteboard, stored: Message) -> Woken:
        """Return each bound module to wake with (after ms, lasttrigger) (OA-WAKE-5/6)."""
        at = (self._index_changes, self._sessions.generation)
        if at != self._routes_at:
            self._routes = {}
            self._routes_at = at
        key = (board.name, stored.type, stored.sender, stored.priority)
        chosen = self._routes.get(key)
        if chosen is None:
            chosen = self._route(board, stored)
            if len(self._routes) >= ROUTE_CACHE_SIZE:
                self._routes = {}
            self._routes[key] = chosen
        if stored.cc:
            modules = self._modules
            with_cc: Woken | None = None
            for name in stored.cc_names:  # OA-CC-1
                if name in modules and name not in chosen:
                    with_cc = with_cc or dict(chosen)
                    with_cc[name] = (0, "")  # OA-CC-2, OA-CC-4; OA-CC-3: others skipped
            if with_cc is not None:
                return with_cc
        return chosen

    def _route(self, board: Whiteboard, stored: Message) -> Woken:
        """Decide the triggered modules afresh (the cache's miss)."""
        modules = self._modules
        folded_board = ascii_fold(board.name)
        sender = stored.sender
        best: dict[str, tuple[int, int]] = {}
        for name, i in self._index.match(stored.type):  # OA-WB-7: registrations current now
            if name not in modules:
                continue  # only a bound module can receive a delivery
            triggers = self._triggers[name]
            _, whiteboard, after = triggers.entries[i]
            if whiteboard and whiteboard != folded_board:
                continue  # OA-TRIG-2: case-insensitive; "" is any whiteboard
            if sender == name and not triggers.allow_self:
                continue  # OA-TRIG-4, OA-REG-6
            if self._qos and not urgent_enough(triggers, i, stored):
                continue  # OA-TRIG-5: an alarm trigger wants time-critical messages only
            current = best.get(name)
            if current is None or (after, i) < current:
                best[name] = (after, i)  # OA-WAKE-6: smallest after, first on a tie
        return {
            name: (after, self._triggers[name].entries[i][0]) for name, (after, i) in best.items()
        }

    def _decide(self, board: Whiteboard, stored: Message, now_ns: int) -> tuple[Delivery, ...]:
        """Decide the wakeups of a stored message (spec 8.6) against the registrations now."""
        chosen = self._woken(board, stored)
        if not chosen:
            return ()
        self._copies.settle()  # keep what the worker encoded for earlier wakeups (issue #19)
        base_ns = board.last_received_ns  # the receivedTime stamped on `stored`
        posted = cmd.ms_time(now_ns)
        trigger = TriggerXml(stored)  # the stored copy is written once per post
        attached, limits = bool(stored.binary), self.limits  # OA-WB-13: its attachments
        deliveries: list[Delivery] = []
        for name in sorted(chosen) if len(chosen) > 1 else chosen:
            after, pattern = chosen[name]
            reg = self.registration(name)
            triggers = self._triggers.get(name)
            if triggers is not None and triggers.registration is reg:
                phase = triggers.phase
            else:
                phase = self._phase_in_force(name, reg)
            retrieved: Sequence[Message] = (
                registration_results(
                    phase.retrieves,
                    board,
                    self._whiteboards,
                    now_ns=now_ns,
                    max_count=limits.max_wakeup_results,  # OA-LIM-9
                    max_bytes=limits.max_wakeup_result_bytes,
                )
                if phase is not None and phase.retrieves
                else ()
            )  # OA-WAKE-7
            omitted, chunked = 0, attached or any(m.binary for m in retrieved)
            if chunked:  # OA-WAKE-11: leave retrieved messages out until the chunks fit
                retrieved, omitted = fit_attachments(stored, retrieved, limits.max_frame_binary)
            parts = WakeupParts(
                trigger=trigger,
                retrieved=retrieved,
                # OA-WAKE-4: an empty phase without a registration
                phase_xml=self._phase_xml(name, reg, phase, pattern),
                whiteboard=board.name,
                module=name,
                id=cmd.fresh_id(),
                posted=posted,
                copies=self._copies,
            )
            build, size = None, 0
            if chunked:
                wakeup = attach_wakeup(parts.write()[0], stored, retrieved, omitted)  # OA-WAKE-10
                wire = None  # the spliced frame has no chunks: the sender writes it
            elif self.defer_large_wakeups and (size := parts.size) > LARGE_WAKEUP:  # #19
                wakeup, wire, build = parts.preview(), None, parts.build
            else:
                wakeup, wire = parts.write()
            deliveries.append(
                Delivery(
                    module=name,
                    message=wakeup,
                    due_ns=base_ns + after * _NS_PER_MS,  # OA-TRIG-3
                    priority=stored.effective_priority,  # OA-PRIO-1
                    wb_priority=board.priority,  # OA-PRIO-2
                    wire=wire,
                    expires_ns=self._expiry(stored, base_ns),  # OA-DELIV-14
                    trigger=stored,
                    build=build,
                    build_bytes=size,
                )
            )
            self._module_counters(name).queued += 1
        board.dispatched += len(deliveries)
        return tuple(deliveries)

    def _expiry(self, msg: Message, received_ns: int) -> int:
        """Return when a delivery of `msg` expires under `qos` (OA-DELIV-14); 0 means never."""
        ttl = msg.timetolive
        if not self._qos or ttl is None or not ttl > 0:
            return 0
        return received_ns + round(ttl * _NS_PER_MS)

    def _phase_xml(
        self, name: str, reg: Registration | None, phase: Phase | None, lasttrigger: str
    ) -> str:
        """Return the PhaseSpec of a wakeup, cached per registration in force and lasttrigger."""
        triggers = self._triggers.get(name)
        if triggers is None or triggers.registration is not reg:
            return phase_spec_xml(phase, module=name, lasttrigger=lasttrigger)
        xml = triggers.phase_xml.get(lasttrigger)
        if xml is None:
            xml = phase_spec_xml(phase, module=name, lasttrigger=lasttrigger)
            if len(triggers.phase_xml) < _PHASE_CACHE_SIZE:
                triggers.phase_xml[lasttrigger] = xml
        return xml
