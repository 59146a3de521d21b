"""How a cluster node reads a whiteboard's stream (OA-CLU-1, OA-CLU-4; spec 17, issue #22).

A node reads each stream with an ordered push consumer (`store.ClusterStore._subscribe`) and
keeps, per whiteboard, what it received and has not handed over yet (`Board`). Two things the
consumer hands over are not taken as they come:

* **a skipped sequence** — an ordered consumer checks its own delivery sequence, not the
  stream's; the copies before a later one are fetched from the stream first (`fill`);
* **the first copies of a new consumer** — JetStream places an R1 ordered consumer on any
  replica of the stream, and a replica that was cut off can still hold copies its partition
  never committed (a post answered STORE_FAILED on that side): seen in the cut-off fault test,
  a node took such a copy at a wbid the majority gave to another, acknowledged post, and skipped
  the acknowledged one as held already. A consumer lives on a replica it was created on, so the
  first `CHECK_FIRST` copies of every consumer (its delivery sequence starts at 1: created by
  the node, by the watchdog, or by nats-py after missed heartbeats) are asked of the stream's
  leader, which answers from the committed log (`committed`).
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from openair.cluster.wire import stream_name
from openair.protocol.message import Message

__all__ = ["CHECK_FIRST", "ID_HEADER", "Board", "LeaderUnreachable", "committed", "fill"]

log = logging.getLogger("openair.cluster")

ID_HEADER = "Nats-Msg-Id"  # the header that names a node's own copy when it comes back

#: Copies of a new consumer checked against the stream's leader (the consumer's delivery
#: sequence up to this). A replica's uncommitted tail is what its side accepted while cut off.
CHECK_FIRST = 128

#: A check is asked this often, this long apart, each answer awaited this long, before the
#: leader counts as unreachable (JetStream electing one answers 503 for seconds).
_CHECK_TRIES = 3
_CHECK_PAUSE_S = 0.25
_CHECK_TIMEOUT_S = 1.0


class LeaderUnreachable(Exception):
    """The stream's leader did not answer a check: the copy cannot be checked now."""


#: Hands one copy over (the store's `_accept`): board, wbid, payload, the copy's id.
Accept = Callable[["Board", int, bytes, "str | None"], None]


@dataclass(slots=True)
class Board:
    """What the consumer of one whiteboard's stream has received and not yet handed over."""

    name: str
    pending: deque[Message] = field(default_factory=deque)
    through: int = 0  # every stream sequence up to this one is received (or discarded)
    stalled_at: int = -1  # `through` when the stream was last seen ahead of it
    sub: Any = None  # the consumer's subscription
    generation: int = 0  # of the subscription: copies from an older one are ignored
    skipped: int = 0  # payloads that did not decode
    filled: int = 0  # copies a consumer skipped, fetched from the stream (OA-CLU-1)
    replaced: int = 0  # copies a new consumer had that the stream's leader holds otherwise
    unchecked: int = -1  # the generation whose copies go unchecked (its leader did not answer)
    lock: asyncio.Lock = field(default_factory=asyncio.Lock)  # one copy taken at a time


async def fill(js: Any, board: Board, seq: int, accept: Accept) -> bool:
    """Fetch from the stream the copies before `seq` the consumer skipped (OA-CLU-1).

    Copies the limit discarded (OA-WB-6) are not missing. False when the stream cannot be read:
    `seq` is not taken and the watchdog reads again from the gap.
    """
    from nats.js.errors import NotFoundError

    name = stream_name(board.name)
    generation = board.generation
    try:
        info = await js.stream_info(name)
        for missing in range(max(board.through + 1, int(info.state.first_seq or 1)), seq):
            try:
                raw = await js.get_msg(name, missing)
            except NotFoundError:
                continue  # discarded since (OA-WB-6)
            if generation != board.generation:
                return False
            accept(board, missing, raw.data or b"", (raw.headers or {}).get(ID_HEADER))
            board.filled += 1
            log.warning("event=cluster_gap_filled whiteboard=%s wbid=%d", board.name, missing)
    except Exception as exc:
        gap = f"from={board.through + 1} to={seq - 1}"
        log.warning("event=cluster_gap whiteboard=%s %s detail=%r", board.name, gap, str(exc))
        return False
    return generation == board.generation


async def committed(
    js: Any, board: Board, seq: int, data: bytes, ident: str | None
) -> tuple[bytes, str | None] | None:
    """The copy at `seq` as the stream's leader holds it, for a copy from a new consumer.

    The leader's copy replaces a different one (counted in `replaced`). None when the copy must
    not be taken yet: the leader holds nothing at `seq` (the replica's copy was never committed,
    or the leader has not applied it yet; also when it said so and then could not say whether
    the limit discarded it); the caller reads again from `seq` later. Raises
    LeaderUnreachable when the leader does not answer: reading must not wait for an election
    (the posts of the node would wait behind it), so the caller takes the copy unchecked.
    """
    from nats.js.errors import NotFoundError

    name = stream_name(board.name)
    for attempt in range(_CHECK_TRIES):
        try:
            raw = await asyncio.wait_for(js.get_msg(name, seq), _CHECK_TIMEOUT_S)
            break
        except NotFoundError:
            try:
                info = await asyncio.wait_for(js.stream_info(name), _CHECK_TIMEOUT_S)
            except Exception:
                return None
            if seq < int(info.state.first_seq or 1):
                return data, ident  # committed once, discarded since by the limit (OA-WB-6)
            log.warning("event=cluster_uncommitted_copy whiteboard=%s wbid=%d", board.name, seq)
            return None
        except Exception as exc:  # JetStream electing a leader answers 503 for a while
            detail = f"whiteboard={board.name} wbid={seq} try={attempt + 1} detail={str(exc)!r}"
            log.warning("event=cluster_check_failed %s", detail)
            await asyncio.sleep(_CHECK_PAUSE_S)
    else:
        raise LeaderUnreachable(f"{board.name}: no answer at wbid {seq}")
    leader = (raw.data or b"", (raw.headers or {}).get(ID_HEADER))
    if leader != (data, ident):
        board.replaced += 1
        log.warning("event=cluster_copy_replaced whiteboard=%s wbid=%d", board.name, seq)
    return leader
