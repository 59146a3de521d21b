"""The harness cases run on: a context per case, modules played by the suite, raw connections.

`CaseContext` (context.py) is what a case function receives; `TestModule` (peer.py) plays one
module on all the paths a server may use; `RawConnection` (raw.py) sends bytes; `Trace`
(trace.py) records the evidence; `probe` (probe.py) measures the target before a run;
`checks.py` takes server messages apart independently of the reference implementation.
"""

from __future__ import annotations

from openair_conformance.harness.context import CaseContext, deadline_for
from openair_conformance.harness.peer import TestModule
from openair_conformance.harness.raw import RawConnection
from openair_conformance.harness.trace import Trace

__all__ = ["CaseContext", "RawConnection", "TestModule", "Trace", "deadline_for"]
