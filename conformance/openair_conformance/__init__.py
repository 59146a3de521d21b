"""OpenAIR conformance suite: drives any OpenAIR server over TCP and judges it by the spec."""

from __future__ import annotations

__version__ = "0.1.0"
