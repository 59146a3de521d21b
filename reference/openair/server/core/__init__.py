"""The sans-I/O server core (issue #17): everything the server decides, nothing it waits for.

`router.Router` (sessions, whiteboards, registrations, wakeups, streams) over
`whiteboard.Whiteboard` and a `store.HistoryStore`; `config` reads psySpec documents. No
sockets, threads or clock reads: the adapter in `openair.server.aio` passes every time in.
"""

from __future__ import annotations
