"""A bytes-level data path in front of the reference router (issue #20).

`select()` picks the data path every new connection uses: `OPENAIR_DATAPATH=reference` (none:
every byte goes through `FrameReader` and the reference decoder), `python` (`pure.PurePath`) or
`native` (`native.NativePath`, the C splitter; an error when the extension is not built). Unset
or empty: native when the extension imported, else python.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from openair.server.aio.datapath.base import DataPath

__all__ = ["MODES", "DataPath", "datapath_of", "default_datapath", "select"]

MODES = ("reference", "python", "native")


def select(env: Mapping[str, str] | None = None) -> DataPath | None:
    """Return the data path `OPENAIR_DATAPATH` asks for; None means the reference path."""
    wanted = (os.environ if env is None else env).get("OPENAIR_DATAPATH", "").strip().lower()
    if wanted not in ("", *MODES):
        raise ValueError(f"OPENAIR_DATAPATH={wanted!r}: expected one of {', '.join(MODES)}")
    if wanted == "reference":
        return None
    from openair.server.aio.datapath.pure import PurePath

    if wanted == "python":
        return PurePath()
    try:
        from openair.server.aio.datapath.native import NativePath
    except ImportError:
        if wanted == "native":
            raise
        return PurePath()
    return NativePath()


_chosen: list[DataPath | None] = []


def default_datapath() -> DataPath | None:
    """Return the data path of this process (`select()` once, at the first connection)."""
    if not _chosen:
        _chosen.append(select())
    return _chosen[0]


def datapath_of(host: object) -> DataPath | None:
    """Return the host's `datapath` attribute when it has one (tests set it), else the default."""
    if hasattr(host, "datapath"):
        chosen: DataPath | None = host.datapath
        return chosen
    return default_datapath()
