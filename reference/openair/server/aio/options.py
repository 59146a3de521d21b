"""How a server is set up: `ServerOptions` and what `start_server` derives from them.

The port to listen on (OA-CONF-7), the configuration to serve, the extensions to advertise
(`durable` only with a durable store, OA-WB-9), the delivery timing with the advertised retry
limits (OA-DELIV-15), the secure-mode gate (OA-AUTH-1) and `free_port` for modules that BIND
without a port. `openair.server.aio.app` runs the server.
"""

from __future__ import annotations

import socket
import ssl
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from openair.server.aio.connhost import FlowLimits
from openair.server.aio.dispatcher import DeliveryOptions
from openair.server.core.auth import AuthGate
from openair.server.core.config import (
    ConfigError,
    ServerConfig,
    ServerLimits,
    default_config,
    load_config,
)
from openair.server.core.store import HistoryStore

__all__ = [
    "DEFAULT_EXTENSIONS",
    "DEFAULT_PORT",
    "ServerOptions",
    "advertised_extensions",
    "auth_gate",
    "config_of",
    "delivery_options",
    "free_port",
    "main_port",
]

#: Extensions the reference server implements; `durable` is added only with a durable store.
DEFAULT_EXTENSIONS = frozenset(
    {"noreply", "pipelining", "usec", "gettime", "typed-streams", "contexts", "qos"}
)
DEFAULT_PORT = 10000


@dataclass(frozen=True, slots=True, kw_only=True)
class ServerOptions:
    """How to run a server: where to listen, what to serve, and its limits and timing."""

    host: str = "127.0.0.1"
    # None: the configuration's <global><port>, else DEFAULT_PORT (OA-CONF-7: a port given
    # here, as on the command line, wins over the configuration's).
    port: int | None = 10000
    config: ServerConfig | None = None
    config_path: str | None = None
    store: str = "memory"
    limits: ServerLimits = field(default_factory=ServerLimits)
    extensions: frozenset[str] = DEFAULT_EXTENSIONS
    grace_s: float = 5.0  # OA-SESS-24
    delivery: DeliveryOptions = field(default_factory=DeliveryOptions)
    flow: FlowLimits = field(default_factory=FlowLimits)
    backlog: int = 1024
    # Each peer address's slice of a loop turn (issue #19, `fairness.Turns`); 0: no fairness.
    fair_slice_s: float = 0.001
    # The web monitor (issue #9, spec 15.2 `monitor`): HTTP on the main port when a connection
    # starts with an HTTP method, and on `http_port` when given. Read-only unless monitor_post.
    monitor: bool = True
    http_port: int | None = None
    monitor_post: bool = False
    monitor_hosts: tuple[str, ...] = ("127.0.0.1", "::1")
    # Secure mode (spec 14.3, extension `auth`): the module secrets; None is legacy mode.
    auth_secrets: Mapping[str, str] | None = field(default=None, repr=False)  # never logged
    tls: ssl.SSLContext | None = None  # TLS on the main port (OA-AUTH-10)


def free_port(requested: int) -> int:
    """Return `requested` if it can be bound on this host, else a free port (binding port 0).

    The router asks for a port when a module BINDs without one (DESIGN-NOTES: the server picks a
    port free on its own host). The socket is closed at once; the module binds it next.
    """
    for port in (requested, 0) if requested > 0 else (0,):
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
            try:
                sock.bind(("", port))
            except OSError:
                continue
            return int(sock.getsockname()[1])
    raise OSError("no free port")


def delivery_options(options: ServerOptions) -> DeliveryOptions:
    """The delivery timing, with the retry and acknowledgement limits the server advertises
    (OA-DELIV-15, OA-DELIV-11)."""
    limits = options.limits
    most = limits.retry_deadline_ms / 1000
    return replace(
        options.delivery,
        retries=limits.delivery_retries,
        deadline_s=limits.ack_deadline_ms / 1000,
        backoff_s=tuple(min(b, most) for b in options.delivery.backoff_s),
    )


def auth_gate(secrets: Mapping[str, str] | None) -> AuthGate | None:
    """Return the secure-mode gate for `secrets`, or None in legacy mode (OA-AUTH-1)."""
    return AuthGate(secrets) if secrets is not None else None


def advertised_extensions(wanted: frozenset[str], store: HistoryStore) -> frozenset[str]:
    """Advertise `durable` only with a durable store (OA-WB-9)."""
    return wanted | {"durable"} if store.durable else wanted - {"durable"}


def main_port(given: int | None, config: ServerConfig) -> int:
    """The port to listen on: the one given, else the configuration's (OA-CONF-7), else 10000."""
    if given is not None:
        return given
    configured = config.port
    if configured is None:
        return DEFAULT_PORT
    if not 0 <= configured <= 65535:
        raise ConfigError(f"<global><port>: not a port number: {configured}")
    return configured


def config_of(options: ServerOptions) -> ServerConfig:
    if options.config is not None:
        return options.config
    if options.config_path is not None:
        return load_config(options.config_path)  # raises ConfigError
    return default_config()
