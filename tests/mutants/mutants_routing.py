"""Mutants of registrations and wakeups (spec section 8): who is woken, when, with what.

Most work on the deliveries of the router's outcomes (mutants_core.outcome_patch): they drop,
duplicate, delay or rewrite wakeups after the router decided them. Registration mutants wrap
`parse_registration` as the router imports it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import pytest
from lxml import etree
from mutants_core import (
    WAKEUP,
    Fn,
    child,
    defer,
    mutant,
    outcome_patch,
    wakeup_object,
    wakeup_patch,
    with_message,
    wrap,
)
from mutants_matching import spec_match

import openair.protocol.registration
from openair.protocol.content import Phase, Registration, RegistrationForm
from openair.protocol.errors import MessageInvalidError
from openair.protocol.message import Message, new_id
from openair.protocol.xmlsafe import local_name
from openair.server.core import commands, router_registrations, router_routes
from openair.server.core.contexts import Contexts
from openair.server.core.router import Delivery, Outcome, Router
from openair.server.core.whiteboard import Whiteboard


def _text(el: etree._Element | None) -> str:
    return (el.text or "").strip() if el is not None else ""


def _board_ok(trigger_from: str, board: str) -> bool:
    return trigger_from.lower() in ("", "any", "*") or trigger_from.lower() == board.lower()


def _matching(root: etree._Element, board: str) -> list[str]:
    """Return the patterns of the wakeup's PhaseSpec triggers that match its TriggerMessage."""
    trigger = child(wakeup_object(root, "TriggerMessage"), "message")
    phase = child(wakeup_object(root, "PhaseSpec"), "phase")
    type_ = _text(child(trigger, "type"))
    if phase is None or not type_:
        return []
    return [
        el.get("type", "")
        for el in phase.iter()
        if isinstance(el.tag, str) and local_name(el) == "trigger"
        if spec_match(el.get("type", ""), type_) and _board_ok(el.get("from", ""), board)
    ]


def _is_wakeup(d: Delivery) -> bool:
    return d.message.type == WAKEUP and bool(d.message.stored)


# --- cc (8.5) ------------------------------------------------------------------------------------


@mutant("cc-needs-registration", "cc wakes only modules that have a registration", "OA-CC-2")
def _cc_needs_registration(mp: pytest.MonkeyPatch) -> None:
    def change(self: Router, d: Delivery) -> Sequence[Delivery]:
        if not _is_wakeup(d) or self.registration(d.module) is not None:
            return (d,)
        phase = child(wakeup_object(etree.fromstring(d.message.content), "PhaseSpec"), "phase")
        return () if phase is None or not phase.get("lasttrigger") else (d,)

    outcome_patch(mp, change)


@mutant("cc-case-insensitive", "cc names match bound names in any case", "OA-CC-1")
def _cc_case_insensitive(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _woken(self: Router, board: Whiteboard, stored: Message) -> dict[str, Any]:
            chosen: dict[str, Any] = original(self, board, stored)
            folded = {name.lower() for name in stored.cc_names}
            for name in list(self._modules):
                if name.lower() in folded and name not in chosen:
                    chosen[name] = (0, "")
            return chosen

        return _woken

    wrap(mp, Router, "_woken", make)


# --- which wakeups (8.4, 8.6) --------------------------------------------------------------------


@mutant("wakeup-per-trigger", "one wakeup per matching trigger and cc, not per module", "OA-WAKE-5")
def _wakeup_per_trigger(mp: pytest.MonkeyPatch) -> None:
    def change(self: Router, d: Delivery) -> Sequence[Delivery]:
        if not _is_wakeup(d):
            return (d,)
        root = etree.fromstring(d.message.content)
        cc = _text(child(child(wakeup_object(root, "TriggerMessage"), "message"), "cc"))
        n = len(_matching(root, d.message.stored)) + (d.module in cc.split(";"))
        copies = [with_message(d, replace(d.message, id=new_id())) for _ in range(n - 1)]
        return (d, *copies)

    outcome_patch(mp, change)


@mutant("after-ignored", "a trigger's after does not delay the wakeup", "OA-TRIG-3")
def _after_ignored(mp: pytest.MonkeyPatch) -> None:
    outcome_patch(mp, lambda self, d: (replace(d, due_ns=0) if _is_wakeup(d) else d,))


@mutant("trigger-from-case-sensitive", "a trigger's from compares case-sensitively", "OA-TRIG-2")
def _trigger_from_case(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(router_routes, "ascii_fold", lambda text: text)
    mp.setattr(router_registrations, "ascii_fold", lambda text: text)


@mutant(
    "decide-late",
    "wakeups are decided three requests later, against the registrations then",
    "OA-WB-7",
)
def _decide_late(mp: pytest.MonkeyPatch) -> None:
    defer(mp, "_decide", lambda self, *args: (), requests=3)


# --- what a wakeup holds (8.7) -------------------------------------------------------------------


@mutant("lasttrigger-empty", "PhaseSpec's lasttrigger is always empty", "OA-WAKE-4")
def _lasttrigger_empty(mp: pytest.MonkeyPatch) -> None:
    def change(root: etree._Element) -> None:
        phase = child(wakeup_object(root, "PhaseSpec"), "phase")
        if phase is not None:
            phase.set("lasttrigger", "")

    wakeup_patch(mp, change)


@mutant("lasttrigger-last-match", "lasttrigger names the last matching trigger", "OA-WAKE-6")
def _lasttrigger_last(mp: pytest.MonkeyPatch) -> None:
    def change(root: etree._Element) -> None:
        phase = child(wakeup_object(root, "PhaseSpec"), "phase")
        trigger = child(wakeup_object(root, "TriggerMessage"), "message")
        found = _matching(root, _text(child(trigger, "stored")))
        if phase is not None and phase.get("lasttrigger") and found:
            phase.set("lasttrigger", found[-1])

    wakeup_patch(mp, change)


@mutant("retrieves-not-run", "registration retrieves are not evaluated", "OA-WAKE-7")
def _retrieves_not_run(mp: pytest.MonkeyPatch) -> None:
    def change(root: etree._Element) -> None:
        collection = child(wakeup_object(root, "RetrievedMessages"), "objectcollection")
        for item in list(collection if collection is not None else ()):
            collection.remove(item)  # type: ignore[union-attr]

    wakeup_patch(mp, change)


@mutant("retrieved-object-missing", "wakeups carry no RetrievedMessages object", "OA-WAKE-3")
def _retrieved_missing(mp: pytest.MonkeyPatch) -> None:
    def change(root: etree._Element) -> None:
        obj = wakeup_object(root, "RetrievedMessages")
        if obj is not None:
            root.remove(obj)

    wakeup_patch(mp, change)


@mutant("trigger-not-stored-copy", "TriggerMessage lacks stored, receivedTime, wbid", "OA-WAKE-2")
def _trigger_not_copy(mp: pytest.MonkeyPatch) -> None:
    def change(root: etree._Element) -> None:
        trigger = child(wakeup_object(root, "TriggerMessage"), "message")
        for el in list(trigger if trigger is not None else ()):
            name = local_name(el) if isinstance(el.tag, str) else ""
            if name == "stored":
                el.text = None
            elif name in ("receivedtime", "wbid"):
                el.getparent().remove(el)  # type: ignore[union-attr]

    wakeup_patch(mp, change)


@mutant("wakeup-stored-empty", "a wakeup's stored slot is empty", "OA-WAKE-1")
def _wakeup_stored_empty(mp: pytest.MonkeyPatch) -> None:
    def change(self: Router, d: Delivery) -> Sequence[Delivery]:
        return (with_message(d, replace(d.message, stored="")) if _is_wakeup(d) else d,)

    outcome_patch(mp, change)


# --- registrations (8.1-8.4) ---------------------------------------------------------------------


def _registration_patch(
    mp: pytest.MonkeyPatch, change: Callable[[Registration], Registration]
) -> None:
    def make(original: Fn) -> Fn:
        def parse(module: str, content: str, **kwargs: Any) -> Registration:
            return change(original(module, content, **kwargs))

        return parse

    wrap(mp, router_registrations, "parse_registration", make)


@mutant("self-trigger-always", "a module's own posts always trigger it", "OA-TRIG-4")
def _self_trigger(mp: pytest.MonkeyPatch) -> None:
    _registration_patch(mp, lambda reg: replace(reg, allow_self_triggering=True))


@mutant("registration-merged", "AIR.Subscribe adds triggers to the old registration", "OA-REG-1")
def _merged(mp: pytest.MonkeyPatch) -> None:
    seen: dict[str, Registration] = {}

    def merge(new: Registration) -> Registration:
        old = seen.get(new.module)
        phase, before = new.active_phase, old.active_phase if old is not None else None
        result = new
        if phase is not None and before is not None:
            added = tuple(t for t in phase.triggers if t not in before.triggers)
            merged = replace(phase, triggers=before.triggers + added)
            result = replace(new, phases=tuple(merged if p is phase else p for p in new.phases))
        seen[new.module] = result
        return result

    _registration_patch(mp, merge)


@mutant(
    "refused-registration-clears",
    "a refused AIR.Subscribe removes the previous registration",
    "OA-REG-8",
)
def _refused_clears(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _subscribe(self: Router, board: Whiteboard, msg: Message, now_ns: int) -> Outcome:
            outcome: Outcome = original(self, board, msg, now_ns)
            if outcome.replies and outcome.replies[0].type != "RECEIVE_ACCEPT":
                self._subscribed.pop(msg.sender, None)
                self._reindex(msg.sender)
            return outcome

        return _subscribe

    wrap(mp, Router, "_subscribe", make)


@mutant("invalid-pattern-accepted", "registrations with bad patterns are accepted", "OA-MATCH-7")
def _invalid_pattern(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(openair.protocol.registration, "validate_pattern", lambda *args, **kwargs: None)
    mp.setattr(openair.protocol.registration, "is_valid_pattern", lambda *args, **kwargs: True)


@mutant("max-triggers-off-by-one", "max-triggers triggers are refused", "OA-LIM-6")
def _max_triggers(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def parse(module: str, content: str, *, max_triggers: int) -> Registration:
            result: Registration = original(module, content, max_triggers=max_triggers - 1)
            return result

        return parse

    wrap(mp, router_registrations, "parse_registration", make)


@mutant(
    "self-cc-ignored",
    "a poster that cc's itself is not woken by the cc",
    "OA-CC-4",
    cases=("FUZZ-001",),  # every barrier relies on the self-cc: the other cases go inconclusive
)
def _self_cc_ignored(mp: pytest.MonkeyPatch) -> None:
    def change(self: Router, d: Delivery) -> Sequence[Delivery]:
        if not _is_wakeup(d):
            return (d,)
        root = etree.fromstring(d.message.content)
        sender = _text(child(child(wakeup_object(root, "TriggerMessage"), "message"), "from"))
        phase = child(wakeup_object(root, "PhaseSpec"), "phase")
        cc_only = phase is None or not phase.get("lasttrigger")
        return () if sender == d.module and cc_only else (d,)

    outcome_patch(mp, change)


@mutant("phasespec-without-triggers", "PhaseSpec lists no triggers", "OA-WAKE-4")
def _phasespec_bare(mp: pytest.MonkeyPatch) -> None:
    def change(root: etree._Element) -> None:
        phase = child(wakeup_object(root, "PhaseSpec"), "phase")
        for el in list(phase.iter() if phase is not None else ()):
            if isinstance(el.tag, str) and local_name(el) == "trigger":
                el.getparent().remove(el)  # type: ignore[union-attr]

    wakeup_patch(mp, change)


@mutant("lost-keeps-registration", "a lost module's registration stays in force", "OA-SESS-15")
def _lost_keeps_registration(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def connection_closed(self: Router, conn: int, **kwargs: Any) -> Outcome:
            before = dict(self._subscribed)
            outcome: Outcome = original(self, conn, **kwargs)
            for name, reg in before.items():
                if name not in self._subscribed:
                    self._subscribed[name] = reg
                    self._reindex(name)
            return outcome

        return connection_closed

    wrap(mp, Router, "connection_closed", make)


@mutant("cc-spaces-kept", "cc names keep the white space around them", "OA-CC-1")
def _cc_spaces(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def _woken(self: Router, board: Whiteboard, stored: Message) -> dict[str, Any]:
            chosen: dict[str, Any] = original(self, board, stored)
            raw = set(stored.cc.split(";"))
            return {n: how for n, how in chosen.items() if how[1] or n in raw}

        return _woken

    wrap(mp, Router, "_woken", make)


@mutant("cc-unbound-refused", "a post whose cc names an unbound module is refused", "OA-CC-3")
def _cc_unbound(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def handle(self: Router, conn: int, msg: Message, **kwargs: Any) -> Outcome:
            outcome: Outcome = original(self, conn, msg, **kwargs)
            unbound = [n for n in msg.cc_names if self.module(n) is None]
            if self.whiteboard(msg.to) is None or not unbound or not outcome.replies:
                return outcome
            err = MessageInvalidError(f"cc names {unbound[0]!r}, which is not bound")
            refusal = commands.error_reply(msg, err, sender=msg.to, now_ns=kwargs["now_ns"])
            return replace(outcome, replies=(refusal,))

        return handle

    wrap(mp, Router, "handle", make)


@mutant("other-context-in-force", "the first phase is in force, whatever its context", "OA-REG-10")
def _other_context(mp: pytest.MonkeyPatch) -> None:
    first = property(lambda self: self.phases[0] if self.phases else None)
    mp.setattr(Registration, "active_phase", first)
    # The same slip in a server with `contexts` (8.9), where the phase in force comes from there.
    mp.setattr(Contexts, "phase", lambda self, module, reg: first.fget(reg) if reg else None)


def _form_patch(
    mp: pytest.MonkeyPatch, form: RegistrationForm, strip: Callable[[Phase], Phase]
) -> None:
    """Apply `strip` to every phase of the registrations that arrive in `form`."""

    def change(reg: Registration) -> Registration:
        if reg.form is not form:
            return reg
        return replace(reg, phases=tuple(strip(p) for p in reg.phases))

    _registration_patch(mp, change)


@mutant("module-form-retrieves-dropped", "<module> form retrieves are ignored", "OA-REG-3")
def _module_retrieves(mp: pytest.MonkeyPatch) -> None:
    _form_patch(mp, RegistrationForm.MODULE, lambda phase: replace(phase, retrieves=()))


@mutant("spec-form-triggers-dropped", "<module><spec> form triggers are ignored", "OA-REG-4")
def _spec_triggers(mp: pytest.MonkeyPatch) -> None:
    _form_patch(mp, RegistrationForm.SPEC, lambda phase: replace(phase, triggers=()))
