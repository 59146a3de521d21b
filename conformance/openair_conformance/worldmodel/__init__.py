"""Conformance checker for world-model implementations (spec section 16, extension `worldmodel`).

The checker joins a whiteboard as a peer module, sends plans and reports to the module under
test and judges its acknowledgements and reports against `schemas/worldmodel.xsd` and the
semantics of 16.5. Cases are `WM-001`…, each citing the OA-WM requirements it checks.
`openair conform-worldmodel HOST:PORT --module NAME` runs them.
"""

from __future__ import annotations

from openair_conformance.worldmodel.cases import CASES, WmCase
from openair_conformance.worldmodel.runner import WmResult, run_cases

__all__ = ["CASES", "WmCase", "WmResult", "run_cases"]
