"""The peers a library is judged against: the reference server, in process, behind the tap.

Every peer kind of schemas/scenario.xsd is the reference server (`openair.server.aio.app`) on a free
port of 127.0.0.1 with the kit's `Tap` in front of it; the scripted kinds make the tap misbehave
(`Behaviour`), and `legacy` also starts the server without extensions. The server's own
connections to the module's bound port are routed through the tap too, by wrapping the server's
`connect` (the method its delivery tasks call), so the kit sees every frame on every path.
"""

from __future__ import annotations

import contextlib
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from openair.server.aio.app import DEFAULT_EXTENSIONS, Server, ServerOptions, start_server
from openair.server.aio.connhost import FlowLimits
from openair_conformance.clientmode.scenario import PeerSpec
from openair_conformance.clientmode.tap import Behaviour, Capture, Tap

__all__ = ["Peer", "behaviour_for", "start_peer"]

_HOST = "127.0.0.1"


@dataclass(slots=True)
class Peer:
    """A running peer: the server, the tap the library connects to, what the server advertises."""

    server: Server
    tap: Tap
    advertised: frozenset[str]

    @property
    def port(self) -> int:
        """The port the library connects to (the tap's)."""
        return self.tap.port

    @property
    def server_address(self) -> tuple[str, int]:
        """Where the kit's own client connects (the server itself, not the tap)."""
        return (_HOST, self.server.port)

    async def stop(self) -> None:
        """Close the tap and stop the server."""
        await self.tap.close()
        with contextlib.suppress(Exception):
            await self.server.stop()


def behaviour_for(spec: PeerSpec, expand: Callable[[str], str]) -> Behaviour:
    """The tap's behaviour for a peer kind; `expand` fills placeholders of `on-type`.

    `on-type` selects the reply to break for close-mid-frame and malformed-frame; for every
    other kind it narrows `delay-ms` to the replies to requests of that type pattern.
    """
    on_type = expand(spec.on_type) if spec.on_type else ""
    breaks = spec.kind in ("close-mid-frame", "malformed-frame")
    return Behaviour(
        keep_receive=spec.kind == "bound-port-delivery",
        legacy=spec.kind == "legacy",
        reply_delay_s=spec.delay_ms / 1000,
        delay_replies_to="" if breaks else on_type,
        cut_reply_to=on_type if spec.kind == "close-mid-frame" else "",
        malform_reply_to=on_type if spec.kind == "malformed-frame" else "",
        drop_push_after=spec.drop_after if spec.kind == "drop-push" else 0,
    )


def _route_deliveries(server: Server, tap: Tap) -> None:
    """Send the server's connections to the module's bound port through the tap."""
    original: Callable[[str, str, int], Awaitable[Any]] | None = getattr(server, "connect", None)
    if original is None:  # a server without the hook: deliveries to the port go untapped
        tap.capture.trace.note("the server's deliveries to the bound port are not captured")
        return

    async def connect(module: str, address: str, port: int) -> Any:
        via = await tap.reverse_port(address, port)
        return await original(module, _HOST, via)

    setattr(server, "connect", connect)  # noqa: B010 -- an instance attribute shadows the method


async def start_peer(spec: PeerSpec, capture: Capture, expand: Callable[[str], str]) -> Peer:
    """Start the server and the tap for one scenario."""
    extensions = frozenset() if spec.kind == "legacy" else DEFAULT_EXTENSIONS
    options = ServerOptions(
        host=_HOST,
        port=0,
        extensions=extensions,
        grace_s=0.2,
        flow=FlowLimits(linger_s=0.2),
    )
    server = await start_server(options)
    tap = Tap(
        (_HOST, server.port),
        capture,
        behaviour=behaviour_for(spec, expand),
        advertised=frozenset(server.extensions),
    )
    try:
        await tap.start(_HOST)
    except BaseException:
        await server.stop()
        raise
    _route_deliveries(server, tap)
    return Peer(server=server, tap=tap, advertised=frozenset(server.extensions))
