"""A server running in a background event loop, for tests whose own thread runs blocking code.

One helper for every test that needs it (the conformance reference run, the engine tests, the
mutant proof): start it with a coroutine factory, call coroutines in its loop, and stop it —
which also cancels whatever tasks a (possibly broken) server left behind and closes the loop,
so no task is destroyed pending when the interpreter exits.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

T = TypeVar("T")


class ServerThread:
    """A server on 127.0.0.1 in a background event loop; `port` is where it listens."""

    def __init__(self, factory: Callable[[], Coroutine[Any, Any, Any]]) -> None:
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._thread.start()
        self.server: Any = self.call(factory())
        self.port: int = int(self.server.port)

    def call(self, coro: Coroutine[Any, Any, T], timeout: float = 30.0) -> T:
        """Run `coro` in the server's loop and return its result."""
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout)

    def stop(self) -> None:
        """Stop the server (a FakeServer's close(), the reference Server's stop())."""
        stop = getattr(self.server, "stop", None) or self.server.close
        with contextlib.suppress(Exception):
            self.call(stop(), timeout=10.0)
        with contextlib.suppress(Exception):  # a broken server may leave tasks behind
            self.call(_cancel_the_rest(), timeout=10.0)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=10.0)
        if not self._thread.is_alive():
            self._loop.close()


async def _cancel_the_rest() -> None:
    """Cancel every other task of this loop and wait for them."""
    me = asyncio.current_task()
    rest = [task for task in asyncio.all_tasks() if task is not me]
    for task in rest:
        task.cancel()
    await asyncio.gather(*rest, return_exceptions=True)


class ReferenceServer(ServerThread):
    """The reference server: `ServerOptions` fields as keywords, on 127.0.0.1 and a free port."""

    def __init__(self, **options: Any) -> None:
        from openair.server.aio.app import ServerOptions, start_server

        opts = ServerOptions(host="127.0.0.1", port=0, **options)
        super().__init__(lambda: start_server(opts))
