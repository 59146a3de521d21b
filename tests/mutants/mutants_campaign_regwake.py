"""Mutants of issue #15 from the third cosmic-ray campaign on registrations and wakeups.

Each was a one-line change the suite once passed with every case green: the informative
children of a phase (`<description>`, `<posts>`, `<crank>`) refused instead of ignored
(OA-REG-4, OA-CONF-6), a phase priority of 0.0 that the PhaseSpec writer refuses (OA-REG-4),
and a PhaseSpec echo that drops a trigger's alias or writes a `maxpriority` the trigger does
not have (OA-WAKE-4). The cases that now catch them are REG-040, REG-041 and WAKE-040.
"""

from __future__ import annotations

import pytest
from lxml import etree
from mutants_core import Fn, mutant, wrap

from openair.protocol import registration
from openair.protocol.content import Trigger
from openair.protocol.errors import ApiMisuseError


@mutant(
    "phase-children-refused",
    "a registration phase holding <description>, <posts> or <crank> is refused",
    "OA-REG-4",
    "OA-CONF-6",
)
def _phase_children_refused(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(registration, "_PHASE_IGNORED", frozenset())


@mutant(
    "phase-priority-zero-refused",
    "the PhaseSpec writer takes a phase priority of 0.0 as out of range",
    "OA-REG-4",
    "OA-WAKE-4",
)
def _phase_priority_zero_refused(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def priority_text(priority: float) -> str:
            if priority == 0.0:
                raise ApiMisuseError("phase priority out of range 0.0-6.999: 0.0")
            text: str = original(priority)
            return text

        return priority_text

    wrap(mp, registration, "_priority_text", make)


@mutant(
    "phase-echo-drops-alias",
    "PhaseSpec writes each trigger without its alias",
    "OA-WAKE-4",
)
def _phase_echo_drops_alias(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def trigger_element(t: Trigger, *, echo: bool = False) -> etree._Element:
            el: etree._Element = original(t, echo=echo)
            if echo and "alias" in el.attrib:
                del el.attrib["alias"]
            return el

        return trigger_element

    wrap(mp, registration, "_trigger_element", make)


@mutant(
    "phase-echo-maxpriority-none",
    'PhaseSpec writes maxpriority="None" on each trigger registered without maxpriority',
    "OA-WAKE-4",
)
def _phase_echo_maxpriority_none(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def trigger_element(t: Trigger, *, echo: bool = False) -> etree._Element:
            el: etree._Element = original(t, echo=echo)
            if t.max_priority is None:
                el.set("maxpriority", "None")
            return el

        return trigger_element

    wrap(mp, registration, "_trigger_element", make)
