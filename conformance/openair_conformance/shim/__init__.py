"""The shim protocol `openair-shim/1` (PROTOCOL.md): its JSON Schema and the kit's driver."""

from __future__ import annotations
