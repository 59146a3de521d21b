"""The web monitor of the reference server (issue #9): live pages and a JSON API over HTTP.

The server calls `attach(server)` when it starts with the monitor on (the default; `openair
serve --no-monitor` turns it off). From then on a main-port connection that starts with an HTTP
request line is served here (OA-EXT-3, as Psyclone's psyProbe was), and so is `--http-port`
when given. Watching costs routing almost nothing: the router's observer only appends to a
ring; pages, filters and live batches are built from it when someone asks (see `tap`, `sse`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from openair_monitor.core import Monitor, MonitorOptions
from openair_monitor.http import HttpLimits

if TYPE_CHECKING:
    from openair.observing import ObservedServer

__all__ = ["HttpLimits", "Monitor", "MonitorOptions", "attach"]


async def attach(server: ObservedServer, options: MonitorOptions | None = None) -> Monitor:
    """Attach a started monitor to `server`, as its ServerOptions say (post, hosts, HTTP port)."""
    opts = server.options
    monitor = Monitor(
        server,
        options,
        post=opts.monitor_post,
        hosts=opts.monitor_hosts,
        http_port=opts.http_port,
    )
    await monitor.start()
    return monitor
