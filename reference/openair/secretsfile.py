"""Read a secrets file of the `auth` extension from disk (spec 14.3, OA-AUTH-1).

The parsing is `openair.protocol.auth.parse_secrets`; this module is the file read the
role-neutral protocol package leaves to its callers (the server and conformance CLIs).
"""

from __future__ import annotations

from pathlib import Path

from openair.protocol.auth import SecretsError, parse_secrets

__all__ = ["load_secrets"]

_MAX_SECRETS_FILE = 1 << 20


def load_secrets(path: str | Path) -> dict[str, str]:
    """Read a secrets file (see `parse_secrets`)."""
    p = Path(path)
    try:
        with p.open("rb") as f:
            data = f.read(_MAX_SECRETS_FILE + 1)
    except OSError as exc:
        raise SecretsError(f"{p}: cannot read: {exc.strerror or exc}") from None
    if len(data) > _MAX_SECRETS_FILE:
        raise SecretsError(f"{p}: larger than {_MAX_SECRETS_FILE} bytes")
    return parse_secrets(data, source=str(p))
