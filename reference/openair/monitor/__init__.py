"""The web monitor of the reference server (issue #9); being built."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from openair.server.app import MonitorHook, Server

__all__ = ["attach"]


async def attach(server: Server) -> MonitorHook | None:
    """Attach the web monitor to `server`; None until the monitor exists."""
    return None
