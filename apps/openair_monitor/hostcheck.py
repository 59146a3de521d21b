"""Which `Host` and `Origin` the monitor answers: a guard against DNS rebinding (issue #19).

A page on an attacker's domain whose name is made to resolve to 127.0.0.1 can make a browser
send requests to the monitor; they carry the attacker's name in `Host` (and `Origin`). The
monitor answers a name only when it is allowed — `localhost`, the address it listens on and the
`--monitor-host` entries — and any IP literal, which no rebinding can produce.
"""

from __future__ import annotations

import ipaddress

__all__ = ["allowed_names", "host_allowed", "origin_allowed"]

_WILDCARDS = frozenset({"", "0.0.0.0", "::"})


def allowed_names(listen_host: str, extra: tuple[str, ...] = ()) -> frozenset[str]:
    """Return the host names (lower case) the monitor answers besides IP literals."""
    names = {"localhost", *(h.strip().lower() for h in extra if h.strip())}
    if listen_host not in _WILDCARDS:
        names.add(listen_host.lower())
    return frozenset(names)


def _host_part(authority: str) -> str:
    """Return the host of `host[:port]` or `[v6]:port`, without brackets, in lower case."""
    authority = authority.strip().lower()
    if authority.startswith("["):
        return authority[1:].partition("]")[0]
    if authority.count(":") == 1:
        return authority.partition(":")[0]
    return authority


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def host_allowed(value: str | None, names: frozenset[str]) -> bool:
    """Return whether a request's `Host` names this monitor (an IP literal or an allowed name)."""
    if value is None:
        return False
    host = _host_part(value)
    return _is_ip(host) or host in names


def origin_allowed(value: str | None, names: frozenset[str]) -> bool:
    """Return whether a request's `Origin` (absent: not a cross-site browser request) is ours."""
    if value is None:
        return True
    scheme, sep, rest = value.strip().partition("://")
    if not sep or scheme.lower() not in ("http", "https"):
        return False  # "null" and other opaque origins
    return host_allowed(rest.partition("/")[0], names)
