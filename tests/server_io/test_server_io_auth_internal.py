"""Secure mode (spec 14.3) with an internal module (OA-CONF-8): the server's own code proves
nothing, and a proved external module exchanges posts with it."""

from __future__ import annotations

import asyncio

import internal_handlers  # noqa: F401 (named in the psySpec)

from openair.client import Module
from openair.protocol.content import Trigger
from openair.server.aio.app import ServerOptions, start_server
from openair.server.core.config import parse_config

SECRETS = {"Alice": "alice-secret-0123456789"}
SPEC = b"""<psySpec name="SecureInternal" version="1.2">
  <whiteboard name="WB1"/>
  <module name="Echo" internal="internal_handlers:Echo">
    <trigger from="WB1" type="Int.Ping"/>
  </module>
</psySpec>"""


def test_an_internal_module_works_in_secure_mode() -> None:
    async def body() -> None:
        config = parse_config(SPEC, source="secure-internal")
        server = await start_server(
            ServerOptions(host="127.0.0.1", port=0, config=config, auth_secrets=SECRETS)
        )
        try:
            async with Module(
                "Alice", port=server.port, listen=False, secret=SECRETS["Alice"]
            ) as alice:
                await alice.subscribe(Trigger(pattern="Int.Pong", whiteboard="WB1"))
                await alice.post("WB1", "Int.Ping", "hello")
                while True:
                    event = await alice.next_wakeup(timeout=10)
                    assert event is not None
                    if event.wakeup.trigger is not None:
                        break
                pong = event.wakeup.trigger
                assert (pong.type, pong.sender, pong.content) == ("Int.Pong", "Echo", "hello")
        finally:
            await server.stop()

    asyncio.run(asyncio.wait_for(body(), 30))
