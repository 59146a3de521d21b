"""Mutation testing of the reference server, judged by the conformance suite (issue 15).

cosmic-ray generates the mutants and keeps the session (sqlite, resumable); the judge (its test
command) starts the mutated server in-process and runs the conformance cases that execute the
mutated line, chosen from a coverage map recorded once per tree (`control`). Nothing here
touches the working tree: every run works in copies under the cache folder (`snapshot`).
`python -m tools.mutation --help` runs a campaign and writes test-artifacts/mutation.md.
"""

from __future__ import annotations

__all__ = ["MODULE_GROUPS", "resolve_modules"]

_CORE = "reference/openair/server/core/"
_AIO = "reference/openair/server/aio/"

#: The modules issue 15 names, by the area they implement; the report groups rows by these.
MODULE_GROUPS: dict[str, tuple[str, ...]] = {
    "routing": (
        _CORE + "router.py",
        _CORE + "router_commands.py",
        _CORE + "router_registrations.py",
        _CORE + "router_routes.py",
        _CORE + "router_state.py",
        _CORE + "router_streams.py",
    ),
    "whiteboard": (_CORE + "whiteboard.py",),
    "retrieve": (_CORE + "retrieve.py",),
    "registration": ("reference/openair/protocol/registration.py",),
    "wakeup": ("reference/openair/protocol/wakeup.py",),
    "delivery": (_AIO + "delivery.py", _AIO + "dispatcher.py", _CORE + "queues.py"),
    "sessions": (_CORE + "sessions.py",),
    "streams": (_CORE + "streams.py", _CORE + "streamservice.py"),
}


def resolve_modules(names: list[str] | tuple[str, ...]) -> list[str]:
    """Return the module paths `names` denote: group names, file stems or relative paths.

    Empty `names` means every module of every group. ValueError for a name that denotes none.
    """
    every = [path for paths in MODULE_GROUPS.values() for path in paths]
    if not names:
        return every
    chosen: list[str] = []
    for name in names:
        hits = list(MODULE_GROUPS.get(name, ()))
        hits += [p for p in every if name in (p, p.rsplit("/", 1)[-1], p.rsplit("/", 1)[-1][:-3])]
        if not hits:
            groups = ", ".join(MODULE_GROUPS)
            raise ValueError(f"unknown module {name!r}: name a group ({groups}) or a file")
        chosen += [p for p in dict.fromkeys(hits) if p not in chosen]
    return chosen


def group_of(path: str) -> str:
    """Return the group a module path belongs to ("other" for a module outside the groups)."""
    for group, paths in MODULE_GROUPS.items():
        if path in paths:
            return group
    return "other"
