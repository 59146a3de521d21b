"""Mutants of issue #15 that the mutation campaign made survive in the streams module's
time lookups after a drop from the middle (`openair.server.core.streams`).

A one-line change the suite once passed with every case green, and a fault a third-party
implementer could make: when the soft limit drops a sample from behind a locked oldest one
(OA-XSTREAM-2, OA-XSTREAM-5), the stream forgets to compare the two samples that become
neighbours, so with timestamps T+100 (locked), T, T+50 it takes T+100, T+50 for ordered and
bisects on them: GET_SAMPLE_BY_TIME T+100 answers the sample stamped T+50 (OA-STREAM-6). No
case dropped a sample from between two whose timestamps fall. The case that now catches it
is XSTREAM-070 (cases/streams_lookup.py).
"""

from __future__ import annotations

import pytest
from mutants_core import mutant

from openair.server.core.streams import Stream


@mutant(
    "stream-order-stale-after-inner-drop",
    "dropping a sample from behind a locked one counts only the falling pair into it, never "
    "the pair of its neighbours, so the stream bisects over timestamps that are not in order",
    "OA-STREAM-6",
    "OA-XSTREAM-2",
)
def _order_stale_after_inner_drop(mp: pytest.MonkeyPatch) -> None:
    def _remove_at(self: Stream, i: int) -> None:
        items = self._items
        prev, st = items[i - 1], items[i]
        self._descents -= prev.timestamp_ms > st.timestamp_ms
        del items[i]
        self.size -= st.size

    mp.setattr(Stream, "_remove_at", _remove_at)
