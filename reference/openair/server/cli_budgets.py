"""The byte and connection budgets of `openair serve` as command-line options (issue #19).

`budget_options` adds one option per budget of spec 14.1 (OA-LIM-8 to OA-LIM-13); the command
receives them in one keyword, `budgets`, a dict of `ServerLimits` fields ready to pass on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

from openair.server.core.config import ServerLimits

__all__ = ["BUDGETS", "budget_options"]

F = TypeVar("F", bound=Callable[..., Any])

_DEFAULTS = ServerLimits()

#: (ServerLimits field, help) in the order of spec 14.1; the option is `--` + the field with `-`.
BUDGETS: tuple[tuple[str, str], ...] = (
    (
        "max_queue_bytes",
        "Bytes of pending deliveries per module; past it the lowest-priority oldest are dropped"
        " and counted QUEUE_OVERFLOW (OA-LIM-8).",
    ),
    ("max_wakeup_results", "Messages a wakeup's retrieves return at most, together (OA-LIM-9)."),
    (
        "max_wakeup_result_bytes",
        "Content bytes a wakeup's retrieves return at most, together (OA-LIM-9).",
    ),
    (
        "max_history_bytes",
        "Bytes of stored copies per whiteboard, besides its maxcount; the oldest go first"
        " (OA-LIM-10).",
    ),
    ("max_connections", "Open client connections in total; more are closed at once (OA-LIM-11)."),
    ("max_connections_per_peer", "Open client connections from one address (OA-LIM-11)."),
    (
        "max_partial_bytes",
        "Bytes of unfinished frames held over all connections; the connection that passes it"
        " gets LIMIT_EXCEEDED and is closed (OA-LIM-12).",
    ),
    (
        "frame_total_deadline_ms",
        "The longest one frame may take from its first byte to its last (OA-LIM-13).",
    ),
    (
        "max_held_bytes",
        "Bytes of stored copies and queued deliveries in all; a post that would pass it is"
        " refused (LIMIT_EXCEEDED) before it is stored or acknowledged (OA-LIM-14).",
    ),
    (
        "module_retention_ms",
        "How long the counters of a module that left are kept before its name is forgotten"
        " (OA-LIM-15).",
    ),
    (
        "stream_push_buffer_bytes",
        "Payload bytes buffered per stream subscriber before its oldest samples are dropped"
        " (OA-LIM-16).",
    ),
    ("max_created_streams", "Streams that clients may create at run time (OA-LIM-17)."),
    (
        "max_created_stream_bytes",
        "The largest maxsize, in bytes, of a stream created at run time (OA-LIM-17).",
    ),
)


def budget_options(command: F) -> F:
    """Add the budget options to a click command, gathered in its `budgets` keyword."""
    for name, text in reversed(BUDGETS):
        command = click.option(
            "--" + name.replace("_", "-"),
            name,
            default=getattr(_DEFAULTS, name),
            show_default=True,
            type=click.IntRange(1, None),
            help=text,
            expose_value=False,  # gathered into `budgets` by the callback instead
            callback=_gather,
        )(command)
    return command


def _gather(ctx: click.Context, param: click.Parameter, value: int) -> None:
    """Move one budget option's value into `ctx.params["budgets"]`."""
    assert param.name is not None
    budgets: dict[str, int] = ctx.params.setdefault("budgets", {})
    budgets[param.name] = value
