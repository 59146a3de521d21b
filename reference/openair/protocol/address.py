"""Server addresses as the command lines write them: `HOST:PORT`, `HOST`, `:PORT`.

A neutral module: the client commands, the ontology tools and the recorder all read
`--server`, and none of them should import another's command-line module to do it.
"""

from __future__ import annotations

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "parse_server"]

DEFAULT_HOST = "127.0.0.1"
#: The main port of a server without a configuration (spec 12).
DEFAULT_PORT = 10000


def parse_server(value: str) -> tuple[str, int]:
    """Split `HOST:PORT` (also `HOST` or `:PORT`; default 127.0.0.1:10000).

    Raises ValueError when the port is not a number in 1–65535.
    """
    host, sep, port_text = value.rpartition(":")
    if not sep:
        host, port_text = value, str(DEFAULT_PORT)
    host = host.strip("[]") or DEFAULT_HOST
    if not port_text.isdigit() or not 0 < int(port_text) < 65536:
        raise ValueError(f"not a port: {port_text!r}")
    return host, int(port_text)
