"""Mutants of issue #15 that the mutation campaign made survive in the stream service
(`openair.server.core.streamservice`).

Each was a one-line change the suite once passed with every case green, and a fault a third-party
implementer could make: the waits of a closed connection kept on their stream, so that the first
add that satisfies one fails and the stream's other waits go unanswered (OA-STREAM-7), and the
stream sources of a registration matched only against the streams that exist when the module
registers, so that a stream created at run time afterwards reaches no subscriber (OA-STREAM-14,
OA-XSTREAM-10). A server reads no request behind a pending wait, so no case had a waiting
connection closed while its wait was pending, and every case registered after creating its
streams. The cases that now catch them are XSTREAM-051 and XSTREAM-050
(cases/streams_service.py).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.server.core.streamservice import StreamService


@mutant(
    "stream-waits-outlive-connection",
    "a closed connection's waits stay on their stream (only the wait table forgets them), so "
    "the first add that satisfies one fails and the stream's other waits go unanswered",
    "OA-STREAM-7",
    cases=("XSTREAM-051",),
)
def _waits_outlive_connection(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def connection_closed(self: StreamService, conn: int) -> None:
            kept = {name: list(state.waits) for name, state in self._states.items()}
            original(self, conn)
            for name, waits in kept.items():
                self._states[name].waits = waits

        return connection_closed

    wrap(mp, StreamService, "connection_closed", make)


@mutant(
    "stream-sources-not-kept",
    "a registration's stream sources are matched against the existing streams only, so a "
    "stream created at run time afterwards reaches no module whose source selects it",
    "OA-STREAM-14",
    "OA-XSTREAM-10",
    cases=("XSTREAM-050",),
)
def _sources_not_kept(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def set_registration(self: StreamService, module: str, *args: Any, **kwargs: Any) -> None:
            original(self, module, *args, **kwargs)
            self._sources.pop(module, None)

        return set_registration

    wrap(mp, StreamService, "set_registration", make)
