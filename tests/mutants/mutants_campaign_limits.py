"""Mutants of issue #15 that the mutation campaign made survive at the exact edge of two 14.1
bounds (`openair.server.core.streamservice`, `openair.server.core.retrieve`).

Each was a one-line change the suite once passed with every case green, and a fault a third-party
implementer could make: a count of streams created at run time that grows by two a creation, so
that max-created-streams is reached after half as many (OA-LIM-17), and the attachment bound of a
retrieve reply checked with >=, so that a reply whose chunks total exactly max-frame-binary is
refused LIMIT_EXCEEDED (OA-RET-15). No case created streams up to the limit or retrieved exactly
max-frame-binary bytes. The cases that now catch them are LIM-050 and LIM-051
(cases/limits_created.py), at small limits.
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, mutant, wrap

from openair.protocol.errors import LimitExceededError
from openair.server.core.retrieve import PreparedRetrieve
from openair.server.core.streamservice import StreamService


@mutant(
    "created-streams-counted-twice",
    "each stream created at run time counts twice against max-created-streams, so creations are "
    "refused LIMIT_EXCEEDED after half the limit",
    "OA-LIM-17",
    limits={"max_created_streams": 4},
    cases=("LIM-050",),
)
def _created_counted_twice(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def create(self: StreamService, *args: Any, **kwargs: Any) -> str:
            name = str(original(self, *args, **kwargs))
            self._created += 1
            return name

        return create

    wrap(mp, StreamService, "create", make)


@mutant(
    "retrieve-binary-bound-inclusive",
    "a retrieve reply whose attachments total exactly max-frame-binary is refused LIMIT_EXCEEDED "
    "(the bound checked with >=)",
    "OA-RET-15",
    limits={"max_frame_binary": 4096},
    cases=("LIM-051",),
)
def _binary_bound_inclusive(mp: pytest.MonkeyPatch) -> None:
    def make(original: Fn) -> Fn:
        def content(self: PreparedRetrieve) -> tuple[str, tuple[bytes, ...]]:
            text, chunks = original(self)
            if sum(len(chunk) for chunk in chunks) >= self.max_binary:
                raise LimitExceededError(
                    f"the attachments exceed max-frame-binary ({self.max_binary})"
                )
            return text, chunks

        return content

    wrap(mp, PreparedRetrieve, "_content", make)
