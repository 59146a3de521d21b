"""Each deliberately broken shim fails the scenario that checks the behaviour it breaks."""

from __future__ import annotations

import pytest
from broken_client_shim import BREAKS
from client_conformance_support import broken_shim, result, run

from openair_conformance.model import Verdict


def test_there_are_enough_broken_shims() -> None:
    assert len(BREAKS) >= 8


@pytest.mark.parametrize("mode", sorted(BREAKS))
def test_a_broken_shim_fails_its_scenario(mode: str) -> None:
    _, scenario, evidence = BREAKS[mode]
    summary = run(broken_shim(mode), [scenario])
    judged = result(summary, scenario)
    assert judged.verdict is Verdict.FAIL, judged.message
    assert evidence in judged.message
    assert judged.divergence is not None and 0 <= judged.divergence < len(judged.trace)
