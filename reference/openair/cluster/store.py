"""Whiteboards in NATS JetStream: the store of a cluster node (spec 17, issue #22).

Each whiteboard is one JetStream stream (`OAWB_<hex of the name>`, subject
`openair.wb.<hex>`): its message limit is the whiteboard's maxcount (discard oldest), its
sequence is the wbid (OA-CLU-1), its replicas and placement tag come from the psySpec
(OA-CLU-6). A post is published and the server answers RECEIVE_ACCEPT only after JetStream's
acknowledgement, which JetStream gives once the message is stored on a majority of the replicas
(OA-CLU-2).

Every node reads every whiteboard's stream in order with an ordered push consumer and buffers
the copies; the server adopts them into its own whiteboards (its read model for retrieve and
the wakeups of the modules connected to it, OA-CLU-4). The NATS client runs on a thread of its
own with its own event loop. A post's acknowledgement waits for it without holding up the
server's loop (`publish_soon`); a retrieve waits (`sync`) for at most `timeout_s`, so a node
cut off from the cluster answers STORE_FAILED instead of hanging.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import itertools
import logging
import secrets
import threading
from collections import deque
from collections.abc import Callable, Coroutine
from functools import partial
from typing import TYPE_CHECKING, Any, TypeVar

from openair.cluster.forwarding import Accept, Forwarding
from openair.cluster.liveness import Liveness
from openair.cluster.reading import CHECK_FIRST, LeaderUnreachable, committed, fill
from openair.cluster.reading import ID_HEADER as _ID
from openair.cluster.reading import Board as _Board
from openair.cluster.tasks import cancel_all, expire, quietly
from openair.cluster.wire import (
    ClusterSpec,
    decode_copy,
    encode_copy,
    parse_spec,
    stream_name,
    subject,
)
from openair.protocol.fastcodec import derived
from openair.protocol.message import Message
from openair.server.core.store import StoreSpecError

if TYPE_CHECKING:
    from openair.server.core.config import ServerConfig, WhiteboardConfig

__all__ = ["ClusterSpec", "ClusterStore", "decode_copy", "encode_copy", "parse_spec", "subject"]

log = logging.getLogger("openair.cluster")
_T = TypeVar("_T")
_WATCH_S = 0.5  # how often a node compares what it read with each stream's end
_HEARTBEAT_S = 1.0  # the ordered consumers' idle heartbeat


class ClusterStore:
    """A `SequencedStore` on NATS JetStream (spec 17); `connect` before use."""

    durable = True

    def __init__(self, spec: ClusterSpec) -> None:
        self.spec = spec
        self.timeout_s = spec.timeout_s
        self._boards: dict[str, _Board] = {}
        self._cond = threading.Condition()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._nc: Any = None
        self._js: Any = None
        self._notify: Callable[[], None] | None = None
        self._scheduled = False
        self._liveness = Liveness(spec.node, self._spawn, lambda: self._notify)
        self._forwarding = Forwarding(spec.node, spec.timeout_s)
        self._outbox: deque[tuple[str, bytes, str, concurrent.futures.Future[int] | None]] = deque()
        self._ids = map(f"{secrets.token_hex(6)}-{{}}".format, itertools.count(1))
        # own copies' ids -> the sequence they come back at (`publish_soon` waits for it)
        self._echoes: dict[str, concurrent.futures.Future[int]] = {}
        self._inflight = 0  # publishes queued or sent, not settled yet
        self._flushing = False
        self._tasks: set[asyncio.Task[None]] = set()
        self.published = 0
        self.failed = 0  # noreply posts JetStream did not store
        self.late = 0  # acknowledged posts not seen back in time (adopted without the earlier)
        self.misnumbered = 0  # acknowledgements whose sequence was not where the copy came back

    def __repr__(self) -> str:
        return f"ClusterStore(node={self.spec.node!r}, urls={','.join(self.spec.urls)!r})"

    # -- life cycle ----------------------------------------------------------------------------

    def connect(self, config: ServerConfig, notify: Callable[[], None] | None = None) -> None:
        """Join the cluster, create the whiteboards' streams and start reading them.

        `notify` is called (from the client's thread) when copies arrive; it must hand over
        to the server's loop (`call_soon_threadsafe`). Raises StoreSpecError when the cluster
        cannot be reached or a stream cannot be created.
        """
        loop = asyncio.new_event_loop()
        self._loop = loop
        self._thread = threading.Thread(
            target=loop.run_forever, name=f"openair-cluster-{self.spec.node}", daemon=True
        )
        self._thread.start()
        self._notify = notify
        try:
            self._call(self._connect(config), self.timeout_s * 4)
        except Exception as exc:
            self.close()
            urls = ",".join(self.spec.urls)
            raise StoreSpecError(f"cannot join the cluster {urls}: {exc!r}") from None

    async def _connect(self, config: ServerConfig) -> None:
        import nats

        self._nc = await asyncio.wait_for(  # the first connection: none of the servers answers
            nats.connect(
                servers=list(self.spec.urls),
                name=f"openair-{self.spec.node}",
                connect_timeout=self.timeout_s,
                max_reconnect_attempts=-1,
                reconnect_time_wait=0.25,
                allow_reconnect=True,
            ),
            self.timeout_s,
        )
        self._js = self._nc.jetstream(timeout=self.timeout_s)
        for wb in config.whiteboards:
            await self._ensure_stream(wb)
            board = self._boards[wb.name] = _Board(wb.name)
            await self._subscribe(board, 1)
        self._spawn(self._watch())
        await self._liveness.start(self._nc)
        await self._forwarding.start(self._nc)

    async def _subscribe(self, board: _Board, start: int) -> None:
        """Read the whiteboard's stream in order from sequence `start` (an ordered consumer)."""
        from nats.js.api import ConsumerConfig, DeliverPolicy

        board.generation += 1  # from now on only the new subscription's copies count
        if board.sub is not None:  # in the background: its server may be the one that died
            self._spawn(quietly(board.sub.unsubscribe()))
        board.sub = await self._js.subscribe(
            subject(board.name),
            stream=stream_name(board.name),
            ordered_consumer=True,
            config=ConsumerConfig(
                deliver_policy=DeliverPolicy.BY_START_SEQUENCE, opt_start_seq=start
            ),
            cb=self._receiver(board, board.generation),
            idle_heartbeat=_HEARTBEAT_S,  # a lost consumer is noticed (and recreated) soon
            pending_msgs_limit=-1,
            pending_bytes_limit=-1,
        )

    async def _watch(self) -> None:
        """Restart a consumer that stopped short of its stream's end (OA-CLU-4, OA-CLU-7).

        An ordered consumer lives on one server; when that server dies the client is meant to
        recreate it, but a node must not depend on that: a board whose stream is ahead of what
        it received, with no progress over two checks, is read again from where it stopped.
        """
        while True:
            await asyncio.sleep(_WATCH_S)
            for board in list(self._boards.values()):
                try:
                    info = await self._js.stream_info(stream_name(board.name))
                except Exception:  # the store is unreachable: look again later
                    continue
                with self._cond:
                    through = board.through
                behind = int(info.state.last_seq or 0) > through
                if behind and board.stalled_at == through:
                    log.warning(
                        "event=cluster_resubscribe whiteboard=%s from=%d", board.name, through + 1
                    )
                    with contextlib.suppress(Exception):
                        await self._subscribe(board, through + 1)
                    board.stalled_at = -1  # the new consumer has two checks to deliver
                    continue
                board.stalled_at = through if behind else -1

    # -- liveness (OA-CLU-7): liveness.py ------------------------------------------------------

    def announce(self, modules: tuple[str, ...]) -> None:
        """Say which modules are bound to this node (called by the server, any thread)."""
        self._liveness.announce(modules)

    def take_lost(self) -> list[str]:
        """The modules of nodes found dead since the last call, for this node to post Lost."""
        return self._liveness.take_lost()

    def lost_again(self, modules: list[str]) -> None:
        """Lost notices that could not be stored: taken again at the next beat."""
        self._liveness.lost_again(modules)

    # -- messages to modules on other nodes (OA-CLU-8): forwarding.py --------------------------

    def accept_forwarded(self, accept: Accept) -> None:
        """How the server queues a message another node forwards to one of its modules."""
        self._forwarding.accept = accept

    def forward_soon(self, msg: Message) -> concurrent.futures.Future[int] | None:
        """Send a message to the node its addressee is bound to: the holder the heartbeats
        name first, then the other live nodes; None when there is no other node to ask."""
        holder = self._liveness.holder(msg.to)
        nodes = [n for n in self._liveness.others() if n != holder]
        if holder is not None:
            nodes.insert(0, holder)
        loop = self._loop
        if not nodes or loop is None:
            return None
        return asyncio.run_coroutine_threadsafe(self._forwarding.send(nodes, msg), loop)

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _ensure_stream(self, wb: WhiteboardConfig) -> None:
        """Create the whiteboard's stream, or bring its limits in line with the psySpec."""
        from nats.js.api import DiscardPolicy, Placement, StorageType, StreamConfig
        from nats.js.errors import NotFoundError

        wanted = StreamConfig(
            name=stream_name(wb.name),
            description=f"OpenAIR whiteboard {wb.name}",
            subjects=[subject(wb.name)],
            max_msgs=wb.maxcount,  # OA-WB-6 on the stream: the oldest go
            discard=DiscardPolicy.OLD,
            storage=StorageType.FILE,
            num_replicas=wb.replicas,  # OA-CLU-6
            placement=Placement(tags=[wb.host]) if wb.host else None,
            duplicate_window=120.0,
        )
        try:
            await self._js.stream_info(wanted.name)
        except NotFoundError:
            await self._js.add_stream(wanted)
            log.info("event=stream_created whiteboard=%s replicas=%d", wb.name, wb.replicas)
            return
        await self._js.update_stream(wanted)

    def _receiver(
        self, board: _Board, generation: int
    ) -> Callable[[Any], Coroutine[Any, Any, None]]:
        async def received(msg: Any) -> None:
            async with board.lock:
                if generation != board.generation:
                    return  # a replaced subscription: its copies interleave with the new one's
                seq = int(msg.metadata.sequence.stream)
                if seq <= board.through:
                    return  # a consumer read again from an earlier point: held already
                if seq > board.through + 1 and not await fill(self._js, board, seq, self._accept):
                    if generation == board.generation:
                        board.generation += 1  # read again from the gap (the watchdog)
                    return
                copy = (msg.data, (msg.headers or {}).get(_ID))
                if int(msg.metadata.sequence.consumer) <= CHECK_FIRST and (
                    board.unchecked != generation  # a new consumer's (reading.py)
                ):
                    try:
                        checked = await committed(self._js, board, seq, *copy)
                    except LeaderUnreachable:
                        board.unchecked = generation  # as it comes: never wait for an election
                        checked = copy
                    if checked is None:
                        if generation == board.generation:
                            board.generation += 1  # not committed: read again from `seq`
                        return
                    copy = checked
                if generation == board.generation:
                    self._accept(board, seq, *copy)

        return received

    def _accept(self, board: _Board, seq: int, data: bytes, ident: str | None) -> None:
        """Hand one copy over: the next after `through` (client thread)."""
        copy = decode_copy(data, seq)
        with self._cond:
            echo = self._echoes.get(ident) if ident is not None else None
            if echo is not None and not echo.done():
                echo.set_result(seq)  # this node's own post: `publish_soon` waits for it
            if copy is None:
                board.skipped += 1
            else:
                board.pending.append(copy)
            board.through = seq
            self._cond.notify_all()
            schedule = not self._scheduled and self._notify is not None
            self._scheduled = True
        if schedule and self._notify is not None:
            self._notify()

    def notified(self) -> None:
        """The server took the notice: the next arrival notifies again."""
        with self._cond:
            self._scheduled = False

    def close(self) -> None:
        loop, self._loop = self._loop, None
        if loop is None:
            return
        if self._nc is not None and loop.is_running():
            try:
                asyncio.run_coroutine_threadsafe(self._nc.close(), loop).result(2.0)
            except Exception as exc:  # closing a client cut off from the cluster
                log.warning("event=cluster_close_error detail=%r", str(exc))
        try:
            asyncio.run_coroutine_threadsafe(cancel_all(), loop).result(2.0)
        except Exception as exc:  # a task that will not end: the thread is a daemon
            log.warning("event=cluster_close_error detail=%r", str(exc))
        loop.call_soon_threadsafe(loop.stop)
        if self._thread is not None:
            self._thread.join(2.0)

    # -- HistoryStore ----------------------------------------------------------------------------

    def load(self, whiteboard: str) -> list[Message]:
        """Everything the whiteboard's stream holds now, oldest first (OA-WB-9)."""
        self.sync(whiteboard)
        return self.take(whiteboard)

    def append(self, whiteboard: str, msg: Message) -> None:
        self.publish(whiteboard, msg)

    def evict(self, whiteboard: str, through_wbid: int) -> None:
        """Nothing to do: the stream's message limit discards the oldest (OA-WB-6)."""

    # -- SequencedStore --------------------------------------------------------------------------

    def publish(self, whiteboard: str, msg: Message) -> int:
        """Publish one copy and wait for `publish_soon`'s answer: the wbid it was stored under."""
        # `_confirm` takes at most three timeouts: the acknowledgement, the copy, the leader.
        return self.publish_soon(whiteboard, msg).result(3 * self.timeout_s + 2.0)

    def publish_soon(self, whiteboard: str, msg: Message) -> concurrent.futures.Future[int]:
        """Publish one copy; the future gets its wbid: the stream sequence it comes back under.

        The copy is the whiteboard's at the sequence the consumer reads it at, which every
        node reads (OA-CLU-1); by then every earlier copy is here to be adopted first. An
        acknowledgement's sequence was seen to name another node's post after a partition
        healed (the store elected leaders again); adopting the own copy there dropped that
        post. When the copy does not come back in time, the acknowledged sequence is used only
        if the stream holds this copy there; otherwise the future fails (STORE_FAILED: it is
        stored, and is adopted when it comes back, OA-CLU-2). Nothing waits on the server's
        loop: a node's modules are answered while another module's post is being replicated.
        """
        loop = self._loop
        if loop is None:
            raise RuntimeError("the cluster store is closed")
        acked: concurrent.futures.Future[int] = concurrent.futures.Future()
        echo: concurrent.futures.Future[int] = concurrent.futures.Future()
        ident = self._enqueue(whiteboard, msg, acked, echo=echo)
        return asyncio.run_coroutine_threadsafe(self._confirm(whiteboard, ident, acked, echo), loop)

    async def _confirm(
        self,
        whiteboard: str,
        ident: str,
        acked: concurrent.futures.Future[int],
        echo: concurrent.futures.Future[int],
    ) -> int:
        """The wbid of one published copy, once acknowledged and back (client thread)."""
        try:
            sequence = await asyncio.wrap_future(acked)
            self.published += 1
            try:
                seq = await asyncio.wait_for(asyncio.wrap_future(echo), self.timeout_s)
            except TimeoutError:
                self.late += 1
                log.warning("event=cluster_late whiteboard=%s wbid=%d", whiteboard, sequence)
                if not await self._holds(whiteboard, sequence, ident):  # OA-CLU-2: maybe later
                    raise TimeoutError(
                        f"{whiteboard}: the post did not come back from the store"
                    ) from None
                return sequence
        finally:
            with self._cond:
                self._echoes.pop(ident, None)
        if seq != sequence:
            self.misnumbered += 1
            log.warning(
                "event=cluster_misnumbered whiteboard=%s acked=%d stored=%d",
                whiteboard,
                sequence,
                seq,
            )
        return seq

    async def _holds(self, whiteboard: str, seq: int, ident: str) -> bool:
        """Whether the stream holds this node's copy `ident` at `seq` (asked of its leader)."""
        try:
            raw = await asyncio.wait_for(
                self._js.get_msg(stream_name(whiteboard), seq), self.timeout_s
            )
        except Exception:
            return False
        return bool((raw.headers or {}).get(_ID) == ident)

    def publish_later(self, whiteboard: str, msg: Message) -> None:
        """Publish one copy without waiting (a noreply post, OA-CLU-5).

        The copy comes back from the stream like another node's, in wbid order; a copy that
        JetStream refuses is counted (`failed`), as a noreply post that fails is not answered.
        """
        self._enqueue(whiteboard, msg, None)

    def _enqueue(
        self,
        whiteboard: str,
        msg: Message,
        done: concurrent.futures.Future[int] | None,
        *,
        echo: concurrent.futures.Future[int] | None = None,
    ) -> str:
        """Queue a publish; one task on the client's loop sends them in order (one wbid order).

        Return the copy's id (its `Nats-Msg-Id`); `echo` gets the sequence it comes back at.
        """
        loop = self._loop
        if loop is None:
            raise RuntimeError("the cluster store is closed")
        ident = next(self._ids)
        item = (whiteboard, encode_copy(derived(msg, wbid=None)), ident, done)
        with self._cond:
            if echo is not None:
                self._echoes[ident] = echo
            self._outbox.append(item)
            self._inflight += 1
            wake = not self._flushing
            self._flushing = True
        if wake:
            loop.call_soon_threadsafe(self._flush_soon)
        return ident

    def _flush_soon(self) -> None:
        self._spawn(self._flush())

    async def _flush(self) -> None:
        """Send what the outbox holds, in order; each ack settles its item (client thread)."""
        loop = asyncio.get_running_loop()
        while True:
            with self._cond:
                if not self._outbox:
                    self._flushing = False
                    return
                whiteboard, payload, ident, done = self._outbox.popleft()
            try:
                ack = await self._js.publish_async(
                    subject(whiteboard),
                    payload,
                    stream=stream_name(whiteboard),
                    headers={_ID: ident},
                )
            except Exception as exc:
                self._settle(done, None, exc)
                continue
            timer = loop.call_later(self.timeout_s, expire, ack)
            ack.add_done_callback(partial(self._acked, done, timer))

    def _acked(
        self,
        done: concurrent.futures.Future[int] | None,
        timer: asyncio.TimerHandle,
        ack: asyncio.Future[Any],
    ) -> None:
        timer.cancel()
        if ack.cancelled():
            self._settle(done, None, TimeoutError("no acknowledgement from the cluster in time"))
        elif ack.exception() is not None:
            self._settle(done, None, ack.exception())
        else:
            self._settle(done, int(ack.result().seq), None)

    def _settle(
        self,
        done: concurrent.futures.Future[int] | None,
        seq: int | None,
        exc: BaseException | None,
    ) -> None:
        with self._cond:
            self._inflight -= 1
            if exc is not None and done is None:
                self.failed += 1
            self._cond.notify_all()
        if exc is not None:
            log.warning("event=cluster_publish_failed detail=%r", str(exc))
        if done is None or done.done():
            return
        if exc is not None:
            done.set_exception(exc)
        else:
            assert seq is not None
            done.set_result(seq)

    def take(self, whiteboard: str, through: int | None = None) -> list[Message]:
        board = self._boards.get(whiteboard)
        if board is None:
            return []
        with self._cond:
            pending = board.pending
            if through is None:
                taken = list(pending)
                pending.clear()
                return taken
            taken = []
            while pending and (pending[0].wbid or 0) < through:
                taken.append(pending.popleft())
            if pending and pending[0].wbid == through:
                pending.popleft()  # the caller's own copy: it adopts its own
            return taken

    def sync(self, whiteboard: str) -> None:
        """Wait until the consumer has received the stream's last message, or read the rest
        from the stream's leader when it stalls (OA-CLU-3); TimeoutError when neither can."""
        with self._cond:  # this node's own posts first: every one sent is settled
            self._cond.wait_for(lambda: self._inflight == 0, self.timeout_s)
        info = self._call(self._js.stream_info(stream_name(whiteboard)), self.timeout_s + 1.0)
        last = int(info.state.last_seq or 0)
        if not last or self._wait_through(whiteboard, last, self.timeout_s):
            return
        # The consumer stalls (after an election JetStream refused consumers for 15 s): the
        # rest is read from the stream's leader, as a gap is (OA-CLU-3).
        with contextlib.suppress(Exception):
            self._call(self._catch_up(self._boards[whiteboard], last), self.timeout_s + 1.0)
        if not self._wait_through(whiteboard, last, 0.0):
            through = self._boards[whiteboard].through
            log.warning(
                "event=cluster_sync_short whiteboard=%s through=%d last=%d",
                whiteboard,
                through,
                last,
            )
            raise TimeoutError(f"{whiteboard}: the stream was not read up to {last} in time")

    async def _catch_up(self, board: _Board, last: int) -> None:
        async with board.lock:  # not beside the receiver: one copy taken at a time
            if board.through < last and await fill(self._js, board, last + 1, self._accept):
                log.warning("event=cluster_caught_up whiteboard=%s wbid=%d", board.name, last)

    # -- helpers ---------------------------------------------------------------------------------

    def _wait_through(self, whiteboard: str, seq: int, timeout_s: float) -> bool:
        board = self._boards[whiteboard]
        with self._cond:
            return self._cond.wait_for(lambda: board.through >= seq, timeout_s)

    def _call(self, coro: Coroutine[Any, Any, _T], timeout_s: float) -> _T:
        loop = self._loop
        if loop is None:
            coro.close()
            raise RuntimeError("the cluster store is closed")
        return asyncio.run_coroutine_threadsafe(coro, loop).result(timeout_s)

    def counters(self) -> dict[str, object]:
        """What STATUS can show of the node's store."""
        with self._cond:
            pending = sum(len(b.pending) for b in self._boards.values())
            skipped = sum(b.skipped for b in self._boards.values())
            filled = sum(b.filled for b in self._boards.values())
            replaced = sum(b.replaced for b in self._boards.values())
        return {
            "node": self.spec.node,
            "published": self.published,
            "failed": self.failed,
            "late": self.late,
            "misnumbered": self.misnumbered,
            "pending": pending,
            "skipped": skipped,
            "filled": filled,
            "replaced": replaced,
            "forwarded": self._forwarding.sent,
            "forwarded_here": self._forwarding.received,
        }
