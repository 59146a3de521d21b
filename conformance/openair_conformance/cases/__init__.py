"""The conformance cases, one module per spec section (framing, envelope, session, …).

Importing this package imports every submodule whose name does not start with `_`, so a new
case module is picked up without editing any list; its `@case` decorators register the cases
(`openair_conformance.registry`).
"""

from __future__ import annotations

import importlib
import pkgutil

for _module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")
