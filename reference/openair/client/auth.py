"""Client side of secure mode (extension `auth`, spec 14.3): prove a name on a connection.

`prove_on_streams` runs AUTH_CHALLENGE and AUTH_RESPONSE on a raw requester connection before it
is turned into a callback or push connection; `prove_on_link` does the same on a `Link`. The
secret never leaves this process: only the HMAC proof travels (OA-AUTH-12).
"""

from __future__ import annotations

import asyncio
import ssl

from openair.client.link import Link
from openair.client.session import ClientConnection, Closed, Reply
from openair.protocol.auth import (
    AUTH_ACCEPT,
    AUTH_CHALLENGE,
    AUTH_NONCE,
    AUTH_RESPONSE,
    EXTENSION,
    proof,
)
from openair.protocol.errors import ConnectionClosedError, RequestFailedError
from openair.protocol.message import Message

__all__ = [
    "AuthRefusedError",
    "check_secure",
    "client_tls_context",
    "prove_on_link",
    "prove_on_streams",
]

_READ_SIZE = 65536


class AuthRefusedError(RequestFailedError):
    """The server refused the proof, or does not run in secure mode (OA-AUTH-12)."""


def client_tls_context(cafile: str | None = None) -> ssl.SSLContext:
    """Return a TLS context that verifies the server (OA-AUTH-10); `cafile` for a private CA."""
    context = ssl.create_default_context(cafile=cafile)
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    return context


def check_secure(advertised: frozenset[str] | None) -> None:
    """Refuse to go on at a server that does not advertise `auth` (OA-AUTH-12)."""
    if advertised is None or EXTENSION not in advertised:
        raise AuthRefusedError("the server does not run in secure mode (no `auth`, OA-AUTH-12)")


def _challenge(name: str) -> Message:
    return Message(type=AUTH_CHALLENGE, sender=name, to="CNS")


def _response(name: str, secret: str, nonce: Message) -> Message:
    if nonce.type != AUTH_NONCE:
        raise AuthRefusedError(f"AUTH_CHALLENGE answered {nonce.type}: {nonce.content.strip()}")
    return Message(
        type=AUTH_RESPONSE,
        sender=name,
        to="CNS",
        content=proof(secret, nonce.content.strip(), name),
    )


def _accepted(reply: Message) -> None:
    if reply.type != AUTH_ACCEPT:
        raise AuthRefusedError(f"AUTH_RESPONSE answered {reply.type}: {reply.content.strip()}")


async def prove_on_link(link: Link, name: str, secret: str, timeout: float | None) -> None:
    """Prove `name` on a requester `Link` (OA-AUTH-2, OA-AUTH-3)."""
    _, nonce = await link.request(_challenge(name), timeout)
    _, reply = await link.request(_response(name, secret, nonce), timeout)
    _accepted(reply)


async def prove_on_streams(
    reader: asyncio.StreamReader,
    writer: asyncio.StreamWriter,
    conn: ClientConnection,
    name: str,
    secret: str,
    timeout: float | None,
) -> None:
    """Prove `name` on a raw connection before its Receive frame (OA-AUTH-6)."""
    async with asyncio.timeout(timeout):
        writer.write(conn.send_request(_challenge(name)))
        nonce = await _one_reply(reader, conn)
        writer.write(conn.send_request(_response(name, secret, nonce)))
        _accepted(await _one_reply(reader, conn))


async def _one_reply(reader: asyncio.StreamReader, conn: ClientConnection) -> Message:
    """Read until the one reply of the request in flight arrives."""
    while True:
        data = await reader.read(_READ_SIZE)
        for event in conn.receive_data(data):
            if isinstance(event, Reply):
                return event.message
            if isinstance(event, Closed):
                raise ConnectionClosedError("the server closed the connection while proving")
        if not data:
            raise ConnectionClosedError("the server closed the connection while proving")
