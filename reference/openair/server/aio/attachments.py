"""The applications a server attaches when it starts (the web monitor), found by entry point."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Coroutine
from importlib.metadata import entry_points
from typing import Protocol

from openair.extras import install_hint, missing_extra
from openair.server.aio.observed import ObservedView

__all__ = ["ATTACHMENTS", "Attach", "MonitorHook", "load_attachment"]

log = logging.getLogger("openair.server")


#: The entry point group of the applications a server attaches when it starts (pyproject.toml:
#: `monitor`, the web monitor). The server never imports them: they attach through `observe`.
ATTACHMENTS = "openair.server.attachments"


#: An installed application's entry point: called once with the started server.
Attach = Callable[[ObservedView], Coroutine[object, object, "MonitorHook"]]


def load_attachment(name: str) -> Attach | None:
    """Load the installed application `name`; None when none is installed or its extra is
    missing (then the server runs without it and says which extra to install)."""
    for entry in entry_points(group=ATTACHMENTS, name=name):
        try:
            attach: Attach = entry.load()
        except ModuleNotFoundError as exc:
            extra = missing_extra(exc)
            if extra is None:
                raise
            log.warning(
                "event=attachment_unavailable name=%s missing=%s install=%s",
                name,
                exc.name,
                install_hint(extra),
            )
            return None
        return attach
    log.warning("event=attachment_missing name=%s group=%s", name, ATTACHMENTS)
    return None


class MonitorHook(Protocol):
    """What the server needs from an attached web monitor (openair_monitor)."""

    def adopt(self, transport: asyncio.Transport, data: bytes) -> None:
        """Serve HTTP on a main-port connection whose first bytes were `data`."""

    async def close(self) -> None:
        """Close the monitor's own listener and its open HTTP connections."""
