"""Background traffic for `run_demo.py --load N`: one loader process, posting as fast as acked.

Posts batches of 256-byte `Load.Noise` messages (pipelined) to LoadWB; loader 0 also runs
`LoadSink`, a module woken by every one of them, so the server routes and delivers the load.
"""

from __future__ import annotations

import asyncio
import sys

from skundar_common import LOAD, ready, run_module, server_address

from openair.client import Module
from openair.protocol.content import Trigger

BATCH = 32


async def sink(host: str, port: int) -> None:
    """Take every load wakeup."""
    async with Module("LoadSink", host, port) as module:
        await module.subscribe([Trigger(pattern="Load.*", whiteboard=LOAD)])
        async for _ in module.wakeups():
            pass


async def main() -> None:
    """Post until stopped."""
    host, port = server_address()
    index = int(sys.argv[1]) if len(sys.argv) > 1 else 0
    tasks = [asyncio.ensure_future(sink(host, port))] if index == 0 else []
    async with Module(f"Load{index}", host, port, listen=False) as module:
        ready()
        batch = [module.message(LOAD, "Load.Noise", "x" * 256) for _ in range(BATCH)]
        try:
            while True:
                await module.post_many(batch)
        finally:
            for task in tasks:
                task.cancel()


if __name__ == "__main__":
    run_module(main)
