"""The secure-mode gate of the reference server (extension `auth`, spec 14.3).

`AuthGate` keeps, per connection, the pending nonce and the names the connection proved, and
screens every request before the router acts on it. Sans-I/O: connections are the adapter's ids,
and the random source is injectable (tests pass a fixed one).
"""

from __future__ import annotations

import secrets as _secrets
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from openair.protocol.auth import (
    AUTH_CHALLENGE,
    AUTH_RESPONSE,
    MIN_SECRET_BYTES,
    NONCE_BYTES,
    SecretsError,
    server_only_type,
    verify,
)
from openair.protocol.errors import AuthFailedError, AuthRequiredError
from openair.protocol.message import Message

__all__ = ["AuthGate", "Refusal"]

ConnId = int
_OPEN_CNS = frozenset({"PING", "KEEPALIVE", "GET_CAPABILITIES", AUTH_CHALLENGE, AUTH_RESPONSE})
_SESSION = frozenset({"PING", "KEEPALIVE"})
_OWN_FAILURE = {
    "BIND": "BIND_ERROR",
    "BIND_NOLISTEN": "BIND_ERROR",
    "AIR.Retrieve": "AIR.Retrieve.Failed",
    "AIR.Retrieves": "AIR.Retrieves.Failed",
}  # OA-AUTH-5, OA-ERR-6: commands with their own failure reply use it


@dataclass(frozen=True, slots=True, kw_only=True)
class Refusal:
    """Why a request is refused: the error, the reply type, and whether to close (OA-AUTH-6)."""

    error: AuthRequiredError
    reply_type: str
    close: bool = False


class AuthGate:
    """Nonces, proved names and the screening rules of secure mode (OA-AUTH-2..8)."""

    def __init__(
        self,
        secrets: Mapping[str, str],
        *,
        random_bytes: Callable[[int], bytes] = _secrets.token_bytes,
    ) -> None:
        for name, secret in secrets.items():
            if len(secret.encode("utf-8")) < MIN_SECRET_BYTES:  # OA-AUTH-1
                raise SecretsError(f"the secret of {name!r} is shorter than 16 bytes")
        self._secrets = dict(secrets)
        self._random = random_bytes
        self._nonces: dict[ConnId, str] = {}
        self._proved: dict[ConnId, set[str]] = {}

    def challenge(self, conn: ConnId) -> str:
        """Return a fresh nonce for `conn`, replacing any pending one (OA-AUTH-2)."""
        nonce = self._random(NONCE_BYTES).hex()
        self._nonces[conn] = nonce
        return nonce

    def respond(self, conn: ConnId, name: str, offered: str) -> None:
        """Prove `name` on `conn`, or raise AuthFailedError; the nonce is used up (OA-AUTH-3)."""
        nonce = self._nonces.pop(conn, None)
        if nonce is None:
            raise AuthFailedError("no AUTH_CHALLENGE is pending on this connection")
        secret = self._secrets.get(name)
        if secret is None or not verify(secret, nonce, name, offered):
            raise AuthFailedError(f"the proof for {name!r} does not verify")
        self._proved.setdefault(conn, set()).add(name)  # OA-AUTH-4: one name at a time

    def proved(self, conn: ConnId, name: str) -> bool:
        """Whether `conn` proved `name`."""
        return name in self._proved.get(conn, ())

    def closed(self, conn: ConnId) -> None:
        """Forget a connection: its proofs end with it (OA-AUTH-4)."""
        self._nonces.pop(conn, None)
        self._proved.pop(conn, None)

    def screen(
        self, conn: ConnId, msg: Message, *, receive: bool, cns: bool, post: bool
    ) -> Refusal | None:
        """Return why a request may not be acted upon, or None (OA-AUTH-5, -6, -8).

        `receive`: it came in a Receive frame; `cns`: it is addressed to CNS; `post`: it goes to
        a whiteboard or is forwarded to a bound module. Negative ids are the server's own
        internal modules (OA-CONF-8): trusted code, like the configuration that names them.
        """
        if conn < 0:
            return None
        if receive:
            if self.proved(conn, msg.sender):
                return None
            err = AuthRequiredError(f"this connection has not proved {msg.sender!r}")
            return Refusal(error=err, reply_type="RECEIVE_ERROR", close=True)  # OA-AUTH-6
        if (cns and msg.type in _OPEN_CNS) or (msg.type in _SESSION and not post):
            return None  # OA-AUTH-5: what a connection may do before it proves a name
        reply_type = _OWN_FAILURE.get(msg.type, "RECEIVE_ERROR")
        if not self.proved(conn, msg.sender):  # OA-AUTH-5, OA-AUTH-7
            detail = (
                f"this connection has not proved {msg.sender!r}"
                if self._proved.get(conn)
                else "prove a name first (AUTH_CHALLENGE, AUTH_RESPONSE)"
            )
            return Refusal(error=AuthRequiredError(detail), reply_type=reply_type)
        if post and server_only_type(msg.type, msg.sender):  # OA-AUTH-8
            err = AuthRequiredError(f"only the server sends {msg.type!r}")
            return Refusal(error=err, reply_type=reply_type)
        return None
