"""Shared by the stream client tests: a reference server with typed streams, and runners.

The psySpec below is test data written for these tests (STREAMS.md section 3 attributes): an
untyped `Stream1`, the typed audio stream of issue #5's scenario and a typed stream with small
soft and hard count limits for locks and alarms.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from typing import Any

from openair.client import Module
from openair.server.aio.app import ServerOptions, start_server
from openair.server.core.config import ServerConfig, ServerLimits, parse_config

TIMEOUT = 30.0

PSYSPEC = b"""\
<psySpec name="Stream client tests" version="1.2">
  <whiteboard name="AIRCentral"/>
  <whiteboard name="WB1">
    <streams>
      <stream name="Stream1" maxsize="10"/>
      <stream name="Audio" type="Input.Audio.Perception" maxsize="1" idle="0"/>
      <stream name="Ring" type="Test.Stream.Ring" maxsize="1" softcount="3" hardcount="5"
              idle="0"/>
      <stream name="Tiny" maxsize="0.0001"/>
    </streams>
  </whiteboard>
  <whiteboard name="WB2">
    <streams><stream name="Stream2" maxsize="10"/></streams>
  </whiteboard>
</psySpec>
"""


def config() -> ServerConfig:
    """The psySpec above, parsed."""
    return parse_config(PSYSPEC, source="streams_support.py")


def run(test: Callable[[], Awaitable[None]]) -> None:
    """Run one async scenario with an overall deadline (a hang fails instead of blocking)."""

    async def bounded() -> None:
        await asyncio.wait_for(test(), TIMEOUT)

    asyncio.run(bounded())


@asynccontextmanager
async def server(**limits: Any) -> AsyncIterator[int]:
    """A reference server on 127.0.0.1 (port 0) with the psySpec above; yields its port."""
    options = ServerOptions(
        host="127.0.0.1",
        port=0,
        config=config(),
        monitor=False,
        limits=ServerLimits(**limits),
    )
    srv = await start_server(options)
    try:
        yield srv.port
    finally:
        await srv.stop()


def module(name: str, port: int, **options: Any) -> Module:
    """A module without keepalives (nothing runs in the background but deliveries)."""
    return Module(name, port=port, keepalive=None, **options)
