"""The OpenAIR reference whiteboard server.

`openair.server.core` is the sans-I/O core (router, sessions, whiteboards, retrieve, streams,
queues, store, config); `openair.server.aio` is the asyncio adapter that drives it (import
`openair.server.aio.app` for `start_server`); `cli_serve`/`cli_budgets` are the `openair serve`
command. This package module imports nothing so that importing any part stays cheap.
"""

from __future__ import annotations
