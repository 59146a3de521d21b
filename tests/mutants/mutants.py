"""The catalogue of mutant servers: the reference server with one deliberate fault each.

Each entry of `CATALOGUE` is a `Mutant`: its id, the fault in words, the requirement IDs it
breaks, and `active()`, the context manager that puts the fault into the server (tests only;
nothing is patched outside the block). The mutants live in modules by spec area:

- mutants_matching.py — type matching (section 5);
- mutants_routing.py — registrations, triggers, cc and wakeups (section 8);
- mutants_store.py — acknowledging, storing and retrieving (sections 7 and 9);
- mutants_wire.py — sessions, replies, delivery order, frames and hostile input (2, 6, 10, 13-15);
- mutants_input.py — reading frames and refusing invalid messages (sections 2, 3, 4, 13);
- mutants_streams.py — streams: ring, ids, lookups, waits, BinaryM, push, limits, locks and
  alarms (section 11);
- mutants_clarified.py — the rules spec 1.0-draft.5 made precise (content globs, the character
  table, pattern limits, literal pattern characters, wbid range, RESOLVE ports, callback paths);
- mutants_contexts.py — contexts and phases (section 8.9, extension `contexts`);
- mutants_attachments.py — issue #21: attachments, the content version, bare stream
  registrations, `qos` (timetolive, alarm triggers) and the bounded payload search;
- mutants_sharpened.py — issue #15: boundaries the examples never touched (retries, time
  windows, rare stored-copy slots, letter case, fractional priorities, every component);
- mutants_faults.py — issue #15: faults from the hand-written set (tests/faults) the suite
  once passed (white space around content, receivedTime to the second);
- mutants_bounds.py — issue #15: faults the mutation campaign made survive (the byte and
  result bounds of 14.1, the PhaseSpec's triggers, the largest valid after);
- mutants_campaign_*.py — issue #15: faults of the 2026-11-29 campaign's survivors worth
  keeping (commands, delivery, routing, sessions, streams, the stream service).

test_mutants.py runs the conformance cases that could catch each mutant against a server
started with it active, and reports which cases catch which mutant.
"""

from __future__ import annotations

import mutants_attachments
import mutants_bounds
import mutants_campaign_commands
import mutants_campaign_delivery
import mutants_campaign_limits
import mutants_campaign_lookup
import mutants_campaign_regwake
import mutants_campaign_routing
import mutants_campaign_sessions
import mutants_campaign_streams
import mutants_campaign_streamservice
import mutants_clarified
import mutants_contexts
import mutants_faults
import mutants_input
import mutants_matching
import mutants_routing
import mutants_sharpened
import mutants_store
import mutants_streams
import mutants_wire
from mutants_core import CATALOGUE, Mutant
from mutants_matching import NO_FAULT, Fault, spec_match

__all__ = ["CATALOGUE", "MODULES", "NO_FAULT", "Fault", "Mutant", "spec_match"]

#: The modules whose import registered the mutants.
MODULES = (
    mutants_matching,
    mutants_routing,
    mutants_store,
    mutants_wire,
    mutants_input,
    mutants_streams,
    mutants_clarified,
    mutants_contexts,
    mutants_attachments,
    mutants_sharpened,
    mutants_faults,
    mutants_bounds,
    mutants_campaign_commands,
    mutants_campaign_delivery,
    mutants_campaign_limits,
    mutants_campaign_lookup,
    mutants_campaign_regwake,
    mutants_campaign_routing,
    mutants_campaign_sessions,
    mutants_campaign_streams,
    mutants_campaign_streamservice,
)
