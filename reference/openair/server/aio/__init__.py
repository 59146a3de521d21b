"""The asyncio adapter of the server (issue #17): sockets, timers, tasks and flow control.

`app.Server` listens and drives `openair.server.core.router.Router`; `protocol` holds one
connection, `delivery`/`pusher`/`internal` carry router outcomes to modules, `scheduling`
orders them, `datapath` splits socket reads, `stores` opens the configured history store.
"""

from __future__ import annotations
