"""The secure-mode cases catch every secure-mode mutant (mutants_auth.py, spec 14.3).

Each mutant runs the AUTH cases against the reference server in secure mode with the fault
active; it is caught when a case ends fail, error, timing or pass-nonstrict (a SHOULD case that
saw its requirement broken). The clean run is
tests/conformance/test_suite_auth_reference.py (every AUTH case passes there).
"""

from __future__ import annotations

import asyncio

import mutants_campaign_replies  # noqa: F401  (registers its secure-mode mutants)
import pytest
from mutants_auth import AUTH_MUTANTS
from server_thread import ServerThread

from openair.catalogue import load_catalogue
from openair.server.aio import app
from openair_conformance.engine import RunOptions, run
from openair_conformance.model import Verdict
from openair_conformance.registry import all_cases

SECRETS = {"AuthCaseA": "secret-of-case-module-a-0123", "AuthCaseB": "secret-of-case-module-b-4567"}
CATCHING = frozenset({Verdict.FAIL, Verdict.ERROR, Verdict.TIMING, Verdict.PASS_NONSTRICT})
#: Which cases caught which mutants in this session (for the last test).
CAUGHT_BY: dict[str, set[str]] = {}


@pytest.mark.parametrize("mutant_id", sorted(AUTH_MUTANTS))
def test_auth_mutant_is_caught(mutant_id: str) -> None:
    mutant = AUTH_MUTANTS[mutant_id]
    with mutant.active():
        options = app.ServerOptions(host="127.0.0.1", port=0, auth_secrets=SECRETS, grace_s=0.2)
        thread = ServerThread(lambda: app.start_server(options))
        try:
            run_options = RunOptions(
                target=("127.0.0.1", thread.port),
                case_globs=("AUTH-*",),
                auth_secrets=SECRETS,
                timeout_scale=0.5,
            )
            summary = asyncio.run(run(run_options))
        finally:
            thread.stop()
    caught = [r for r in summary.results if r.verdict in CATCHING]
    for r in caught:
        CAUGHT_BY.setdefault(r.info.id, set()).add(mutant_id)
    assert caught, f"{mutant_id} ({mutant.description}) survived: " + "; ".join(
        f"{r.info.id} {r.verdict.value}" for r in summary.results
    )


def test_auth_mutants_cite_catalogue_requirements() -> None:
    catalogue = load_catalogue()
    assert len(AUTH_MUTANTS) >= 10
    for m in AUTH_MUTANTS.values():
        assert m.requirements and all(r in catalogue for r in m.requirements), m.id


def test_every_auth_case_catches_a_mutant() -> None:
    """Each AUTH case fails on at least one one-line fault (runs after the mutants above)."""
    if len({m for ms in CAUGHT_BY.values() for m in ms}) < len(AUTH_MUTANTS):
        pytest.skip("needs the whole mutant run of this file")
    cases = sorted(c.info.id for c in all_cases() if c.info.id.startswith("AUTH-"))
    assert [c for c in cases if c not in CAUGHT_BY] == []
