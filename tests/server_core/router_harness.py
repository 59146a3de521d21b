"""A small driver for `Router` in tests: messages in, outcomes out, a fake clock."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.protocol.wakeup import Wakeup, parse_wakeup
from openair.server.core.config import ServerConfig, ServerLimits, default_config
from openair.server.core.router import Outcome, Router
from openair.server.core.store import HistoryStore, MemoryStore

T0 = 1_795_328_337_000_000_000
MS = 1_000_000
EXTENSIONS = frozenset({"noreply", "pipelining", "usec", "gettime"})


class Harness:
    """Drive one Router; each call advances the fake clock by one millisecond."""

    def __init__(
        self,
        config: ServerConfig | None = None,
        *,
        store: HistoryStore | None = None,
        limits: ServerLimits | None = None,
        extensions: frozenset[str] = EXTENSIONS,
        port_allocator: Callable[[int], int] | None = None,
    ) -> None:
        self.router = Router(
            config or default_config(),
            store or MemoryStore(),
            server_name="openair-kit/test",
            address="127.0.0.1",
            port=10000,
            limits=limits or ServerLimits(),
            extensions=extensions,
            port_allocator=port_allocator,
        )
        self.now = T0
        self.router.start(self.now)

    def tick(self) -> int:
        self.now += MS
        return self.now

    def send(self, conn: int, msg: Message, *, tag: FrameTag = FrameTag.MESSAGE) -> Outcome:
        now = self.tick()
        return self.router.handle(conn, msg, tag=tag, received_ns=now, now_ns=now)

    def request(
        self, conn: int, type_: str, *, to: str = "CNS", sender: str = "", **kw: Any
    ) -> Outcome:
        return self.send(conn, Message(type=type_, to=to, sender=sender, **kw))

    def reply(self, conn: int, type_: str, **kw: Any) -> Message:
        """Send a request and return its one reply."""
        outcome = self.request(conn, type_, **kw)
        assert len(outcome.replies) == 1, outcome
        return outcome.replies[0]

    def bind(self, conn: int, name: str, **kw: Any) -> Outcome:
        outcome = self.request(conn, "BIND", sender=name, **kw)
        assert outcome.replies[0].type == "BIND_ACCEPT", outcome
        return outcome

    def subscribe(self, conn: int, name: str, xml: str, *, to: str = "AIRCentral") -> Outcome:
        return self.request(
            conn, "AIR.Subscribe", to=to, sender=name, content=xml, content_is_xml=True,
            language="xml",
        )  # fmt: skip

    def post(
        self, conn: int, type_: str, *, to: str = "WB1", sender: str = "Poster", **kw: Any
    ) -> Outcome:
        return self.request(conn, type_, to=to, sender=sender, **kw)

    def close(self, conn: int) -> Outcome:
        return self.router.connection_closed(conn, now_ns=self.tick())


def wakeups(outcome: Outcome) -> dict[str, Wakeup]:
    """Return the trigger wakeups of an outcome by module (phase updates left out)."""
    found: dict[str, Wakeup] = {}
    for delivery in outcome.deliveries:
        if delivery.message.type != "AIR.Instruct.Wakeup":
            continue
        wakeup = parse_wakeup(delivery.message)
        if wakeup.trigger is not None:
            assert delivery.module not in found, "two wakeups for one module (OA-WAKE-5)"
            found[delivery.module] = wakeup
    return found
