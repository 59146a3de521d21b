"""Secure mode (extension `auth`, spec 14.3): proofs, secrets files and server-only types.

Sans-I/O: no sockets, no clock, no files (`openair.secretsfile.load_secrets` reads a secrets
file). The server's per-connection state lives in
`openair.server.core.auth`; clients compute their proof with `proof()`.

The proof for a name N and a nonce X is hex HMAC-SHA256(secret, "OpenAIR-auth/1" LF X LF N)
(OA-AUTH-3). The secret never travels (OA-AUTH-12).
"""

from __future__ import annotations

import hashlib
import hmac
from collections.abc import Mapping
from xml.sax.saxutils import quoteattr

from openair.protocol.errors import OpenAIRError
from openair.protocol.xmlsafe import parse_xml

__all__ = [
    "AUTH_ACCEPT",
    "AUTH_CHALLENGE",
    "AUTH_NONCE",
    "AUTH_RESPONSE",
    "EXTENSION",
    "MIN_SECRET_BYTES",
    "NONCE_BYTES",
    "SecretsError",
    "parse_secrets",
    "proof",
    "secrets_xml",
    "server_only_type",
    "verify",
]

EXTENSION = "auth"
AUTH_CHALLENGE = "AUTH_CHALLENGE"
AUTH_NONCE = "AUTH_NONCE"
AUTH_RESPONSE = "AUTH_RESPONSE"
AUTH_ACCEPT = "AUTH_ACCEPT"
NONCE_BYTES = 32  # OA-AUTH-2
MIN_SECRET_BYTES = 16  # OA-AUTH-1
_LABEL = "OpenAIR-auth/1"
_HEX = frozenset("0123456789abcdef")


class SecretsError(ValueError):
    """A secrets file that cannot be used (unreadable, malformed, a weak or repeated entry)."""


def proof(secret: str | bytes, nonce: str, name: str) -> str:
    """Return the proof of `name` for `nonce`: lowercase hex HMAC-SHA256 (OA-AUTH-3)."""
    key = secret.encode("utf-8") if isinstance(secret, str) else secret
    data = f"{_LABEL}\n{nonce}\n{name}".encode()
    return hmac.new(key, data, hashlib.sha256).hexdigest()


def verify(secret: str | bytes, nonce: str, name: str, offered: str) -> bool:
    """Check an offered proof in constant time (OA-AUTH-3); malformed offers fail."""
    offered = offered.strip()
    if len(offered) != 64 or not set(offered) <= _HEX:
        return False
    return hmac.compare_digest(proof(secret, nonce, name), offered)


def server_only_type(type_: str, sender: str) -> bool:
    """Whether only the server may send a message of `type_` (OA-AUTH-8).

    `AIR.Instruct.Wakeup` and `Psyclone.Module.*` are the server's, except the phase change a
    module posts itself (8.9) and the `Psyclone.Module.Connect.<its own name>` (JavaOpenAIR) or
    `Reconnect.<its own name>` (the kit's clients) that a module posts after binding.
    """
    folded = type_.lower()  # types compare ignoring ASCII case; non-ASCII never matches below
    if folded == "air.instruct.wakeup":
        return True
    if not folded.startswith("psyclone.module."):
        return False
    if folded == "psyclone.module.report.phasechange":
        return False
    own = sender.lower()
    return folded not in (f"psyclone.module.connect.{own}", f"psyclone.module.reconnect.{own}")


def parse_secrets(data: bytes, *, source: str = "secrets") -> dict[str, str]:
    """Read `<secrets><module name secret/>…</secrets>`; raise SecretsError (OA-AUTH-1)."""
    try:
        root = parse_xml(data)
    except OpenAIRError as exc:  # OA-SEC-1, OA-SEC-2: the hardened parser
        raise SecretsError(f"{source}: not a secrets file: {exc}") from None
    if root.tag != "secrets":
        raise SecretsError(f"{source}: the root element must be <secrets>, not <{root.tag}>")
    secrets: dict[str, str] = {}
    for el in root:
        if not isinstance(el.tag, str):
            continue  # comments and processing instructions
        line = el.sourceline
        name, secret = el.get("name", ""), el.get("secret", "")
        if el.tag != "module" or not name:
            raise SecretsError(f"{source}:{line}: expected <module name=… secret=…/>")
        if len(secret.encode("utf-8")) < MIN_SECRET_BYTES:
            raise SecretsError(f"{source}:{line}: the secret of {name!r} is shorter than 16 bytes")
        if name in secrets:
            raise SecretsError(f"{source}:{line}: {name!r} has two secrets")
        secrets[name] = secret
    return secrets


def secrets_xml(secrets: Mapping[str, str]) -> str:
    """Write a secrets file's text (for tools and tests); names and secrets are escaped."""
    rows = "".join(
        f"  <module name={quoteattr(n)} secret={quoteattr(s)}/>\n" for n, s in secrets.items()
    )
    return f"<secrets>\n{rows}</secrets>\n"
