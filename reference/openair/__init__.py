"""OpenAIR 1.0 reference implementation: the sans-I/O protocol core, server, client and CLI.

The normative text is ``spec/openair-1.0.md``; code cites its requirement IDs (``OA-…``).
"""

from __future__ import annotations

__version__ = "0.1.0"
