"""The OpenAIR reference whiteboard server.

The sans-I/O core is `router.Router` (sessions, whiteboards, registrations, wakeups) over
`whiteboard.Whiteboard` and a `store.HistoryStore`; `config` reads psySpec files. The asyncio
adapter (`protocol`, `queues`, `app`) drives the router; import `openair.server.app` for
`start_server`. This package module imports nothing so that importing any part stays cheap.
"""

from __future__ import annotations
