"""Which extra of openair-kit installs a missing optional package (pyproject.toml).

The command line (`openair.cli`) and the server (an attachment whose package is not installed,
openair.observing) name the extra instead of failing with a traceback: `pip install
'openair-kit[monitor]'`. This module imports nothing.
"""

from __future__ import annotations

__all__ = ["OPTIONAL", "install_hint", "missing_extra"]

#: Optional top-level packages -> the extra of openair-kit that installs them (pyproject.toml).
OPTIONAL = {
    "hypothesis": "fuzz",
    "xmlschema": "worldmodel",
    "selenium": "browser",
    "h11": "monitor",  # the web monitor's HTTP (`openair serve`, `openair monitor FILE`)
    "graphviz": "ontology",  # `openair ontology` diagrams
}


def missing_extra(exc: ModuleNotFoundError) -> str | None:
    """Return the extra that provides the missing module of `exc`, or None (a real error)."""
    top = (exc.name or "").partition(".")[0]
    return OPTIONAL.get(top)


def install_hint(extra: str) -> str:
    """The command that installs `extra`."""
    return f"pip install 'openair-kit[{extra}]'"
