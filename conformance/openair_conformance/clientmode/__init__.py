"""Client mode of the conformance kit: judge a client library through its shim.

`openair conform-client --shim "CMD ARGS"` (client_cli.py) runs the scenarios of
`scenarios/*.xml` (scenario.py) against the library: each scenario starts the reference server
behind the kit's frame-capturing proxy (peers.py, tap.py), starts the shim (shim/driver.py),
plays its steps (runner.py), checks everything the library put on the wire (wirechecks.py), and
becomes a `CaseResult` judged like a server-mode case (engine.py).
"""

from __future__ import annotations
