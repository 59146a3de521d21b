"""A thin synchronous wrapper over `Module` for scripts (no threads).

`BlockingModule` owns a private event loop and runs it in the calling thread, only while one of
its methods runs: between calls nothing happens on the module's connections, and deliveries wait
in the kernel's buffers (and in the server's queue) until the next call, typically
`next_wakeup()`. It cannot be used from inside a running event loop; use `Module` there.
"""

from __future__ import annotations

import asyncio
from collections.abc import Coroutine, Iterable, Sequence
from types import TracebackType
from typing import Any, TypeVar

from openair.client.module import MessageEvent, Module, WakeupEvent
from openair.protocol.content import Registration, RetrieveSpec, TcpLocation, Trigger
from openair.protocol.errors import ApiMisuseError
from openair.protocol.message import Message
from openair.protocol.objects import Capabilities

_T = TypeVar("_T")


class BlockingModule:
    """A `Module` driven synchronously; takes the same arguments as `Module`.

    Use as a context manager (`with BlockingModule("Reader") as m:`) or call `connect()` and
    `close()`. Every method blocks until its request is answered or times out.
    """

    def __init__(
        self, name: str, host: str = "127.0.0.1", port: int = 10000, **options: Any
    ) -> None:
        self._runner = asyncio.Runner()
        self.module = Module(name, host, port, **options)

    def _run(self, coro: Coroutine[Any, Any, _T]) -> _T:
        """Run one coroutine on the private loop, in this thread."""
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            return self._runner.run(coro)
        coro.close()
        raise ApiMisuseError("BlockingModule cannot run inside an event loop; use Module")

    def __enter__(self) -> BlockingModule:
        self.connect()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def name(self) -> str:
        """The module's name."""
        return self.module.name

    @property
    def capabilities(self) -> Capabilities | None:
        """The server's CAPABILITIES, or None for a legacy server."""
        return self.module.capabilities

    @property
    def legacy(self) -> bool:
        """True when the server answered GET_CAPABILITIES with UNKNOWN_COMMAND (OA-CAP-2)."""
        return self.module.legacy

    def connect(self) -> None:
        """Connect, bind and start receiving (see `Module.connect`)."""
        self._run(self.module.connect())

    def close(self) -> None:
        """Close the module and the private loop."""
        try:
            self._run(self.module.close())
        finally:
            self._runner.close()

    def post(self, to: str, type: str, content: str = "", **options: Any) -> Message:
        """Post a message and wait for RECEIVE_ACCEPT (see `Module.post`)."""
        return self._run(self.module.post(to, type, content, **options))

    def post_many(self, messages: Iterable[Message]) -> list[Message]:
        """Post several messages, pipelined when the server allows it."""
        return self._run(self.module.post_many(messages))

    def subscribe(
        self,
        triggers: str | Trigger | Iterable[str | Trigger],
        retrieves: Iterable[RetrieveSpec] = (),
        *,
        allow_self_triggering: bool = False,
    ) -> Registration:
        """Replace the module's registration (see `Module.subscribe`)."""
        return self._run(
            self.module.subscribe(triggers, retrieves, allow_self_triggering=allow_self_triggering)
        )

    def retrieve(
        self, specs: RetrieveSpec | Sequence[RetrieveSpec], *, to: str = "AIRCentral"
    ) -> list[Message]:
        """Retrieve stored messages, newest first."""
        return self._run(self.module.retrieve(specs, to=to))

    def resolve(self, name: str) -> TcpLocation:
        """Ask CNS where a component listens."""
        return self._run(self.module.resolve(name))

    def ping(self) -> float:
        """PING the server; return the round-trip time in seconds."""
        return self._run(self.module.ping())

    def next_wakeup(self, timeout: float | None = None) -> WakeupEvent | None:
        """Run the loop until a wakeup arrives; None after `timeout` seconds."""
        return self._run(self.module.next_wakeup(timeout))

    def next_message(self, timeout: float | None = None) -> MessageEvent | None:
        """Run the loop until a directly delivered message arrives; None after `timeout`."""
        return self._run(self.module.next_message(timeout))
