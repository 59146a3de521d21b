"""The Python shim without its stream commands: a binding whose stream API is not done yet.

`python streamless_client_shim.py` speaks `openair-shim/1` like `python -m openair.client.shim`
but answers every stream command as a command it does not know (API_MISUSE "unknown command"),
as PROTOCOL.md asks of a shim whose library has no streams.
"""

from __future__ import annotations

import sys

from openair.client import shim


class StreamlessShim(shim.Shim):
    """The Python shim with the stream commands taken out."""

    def __init__(self) -> None:
        super().__init__()
        for name in self.streams.commands:
            del self._commands[name]


if __name__ == "__main__":
    shim.Shim = StreamlessShim  # type: ignore[misc]  # serve() builds the shim by this name
    sys.exit(shim.main())
