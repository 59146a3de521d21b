"""Every MUST and SHOULD of the catalogue that a server can be judged on has a conformance case.

Requirements no case can check over TCP are listed in `NOT_CHECKED`, each with its reason; the
list is kept honest in both directions (a listed requirement that a case now cites, or that no
longer exists, fails the test too).
"""

from __future__ import annotations

from openair.catalogue import load_catalogue
from openair_conformance.registry import all_cases
from openair_conformance.worldmodel import CASES as WORLDMODEL_CASES

_CLIENT = "a rule for clients or modules; the suite plays the client, the server is judged"
_CONFIG = "about reading a configuration at start-up: not observable over TCP"

NOT_CHECKED: dict[str, str] = {
    "OA-GEN-1": "the definition of conformance itself; the other requirements check it",
    "OA-GEN-3": _CLIENT + " (a library's error classes)",
    "OA-GEN-5": "about a client library's shim and its standard input and output, not the wire",
    "OA-MSG-14": _CLIENT + " (refusing to encode characters XML cannot carry)",
    "OA-SESS-33": _CLIENT + " (pairing replies; the harness does it)",
    "OA-SESS-27": _CLIENT + " (a requester's reply timeout)",
    "OA-SESS-11": _CLIENT + " (a module answering the server's requests)",
    "OA-DELIV-2": _CLIENT + " (a module accepting deliveries on both paths)",
    "OA-DELIV-10": _CLIENT + " (a module keeping its port open)",
    "OA-DELIV-4": _CLIENT + " (a module acknowledging deliveries)",
    "OA-WAKE-8": _CLIENT + " (a module accepting phase updates)",
    "OA-PRIO-4": _CLIENT + " (what a module or test may expect)",
    "OA-ERR-8": _CLIENT + " (a requester classifying RECEIVE_ERROR)",
    "OA-LIM-7": _CLIENT + " (a peer staying within advertised limits)",
    "OA-CAP-2": _CLIENT + " (a client treating a legacy server as legacy; the probe does it)",
    "OA-KEEP-1": "needs 60 s without traffic before the server's KEEPALIVE is due",
    "OA-KEEP-3": "needs 60 s without traffic before the server sends a KEEPALIVE to ignore",
    "OA-DELIV-11": "needs the 10 s delivery deadline to pass",
    "OA-DELIV-7": (
        "a retry may come at any time after a failure; without waiting a bounded time the suite "
        "cannot show that the count of attempts is final"
    ),
    "OA-SESS-24": "needs the server to be shut down, which the suite cannot request",
    "OA-CONF-1": _CONFIG,
    "OA-CONF-3": _CONFIG,
    "OA-CONF-5": _CONFIG + " (needs a configured module, which the suite cannot know of)",
    "OA-CONF-6": _CONFIG,
    "OA-CONF-7": _CONFIG,
    "OA-WM-5": "active functions are code inside the implementation; a peer cannot attach one",
    "OA-WM-8": "about the writer's clock; a peer sees timestamps, not how they were taken",
    "OA-WM-9": "report filters are the implementation's own configuration, not set by a peer",
    "OA-WM-13": "about what a module does when it joins, before the checker can talk to it",
}


def _cited() -> set[str]:
    # The world-model cases (spec 16) judge a module, not the server: their own small table.
    wm = {req for item in WORLDMODEL_CASES for req in item.requirements}
    return {req for item in all_cases() for req in item.info.requirements} | wm


def test_every_must_and_should_has_a_case() -> None:
    cited = _cited()
    missing = [
        f"{req.id} ({req.level}): {req.text[:80]}"
        for req in load_catalogue().values()
        if req.level in ("MUST", "SHOULD") and req.id not in cited and req.id not in NOT_CHECKED
    ]
    assert not missing, "requirements without a case:\n" + "\n".join(missing)


def test_not_checked_list_is_current() -> None:
    catalogue = load_catalogue()
    unknown = sorted(set(NOT_CHECKED) - set(catalogue))
    assert not unknown, f"listed but not in the catalogue: {unknown}"
    now_cited = sorted(set(NOT_CHECKED) & _cited())
    assert not now_cited, f"listed as not checked but cited by a case: {now_cited}"
    assert all(reason.strip() for reason in NOT_CHECKED.values())
