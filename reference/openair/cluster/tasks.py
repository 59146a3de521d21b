"""Small helpers for the cluster client's own event loop (spec 17, issue #22)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Coroutine
from typing import Any

__all__ = ["cancel_all", "expire", "quietly"]


async def quietly(coro: Coroutine[Any, Any, Any]) -> None:
    with contextlib.suppress(Exception):
        await coro


async def cancel_all() -> None:
    """Cancel every other task of the client's loop (the client's own helpers) and wait."""
    tasks = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)


def expire(ack: asyncio.Future[Any]) -> None:
    if not ack.done():
        ack.cancel()
