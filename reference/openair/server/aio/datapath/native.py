"""The native data path (issue #20): the pure path with the frame splitter in C.

Importing this module raises ImportError when the extension was not built (no compiler when
the package was built): `select()` then falls back to the pure path, or refuses
`OPENAIR_DATAPATH=native`.
"""

from __future__ import annotations

from openair.server.aio.datapath import _native  # type: ignore[attr-defined]
from openair.server.aio.datapath.pure import PurePath

__all__ = ["NativePath"]


class NativePath(PurePath):
    """The pure path's decisions, the C extension's frame splitting and marker search."""

    name = "native"

    def __init__(self) -> None:
        super().__init__()
        self.split = _native.split
        self.find_marker = _native.find_marker  # linear in C (issue #19)
