"""Attribute packets: ⟨value, accuracy, confidence, timestamp⟩ and their last-writer-wins order.

A packet's `timestamp` is the observation time in microseconds since the epoch (OA-WM-2), not a
message's posted or received time. `source` and `seq` name the writer and its report sequence
number; with the timestamp and the value they give the total order that decides which of two
packets for the same attribute a replica keeps (OA-WM-6). Taking the maximum under a total order
is commutative, associative and idempotent, so replicas that received the same set of packets in
any order, with any duplicates, hold the same state.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

__all__ = ["Context", "Packet", "PacketKey", "Ref", "Value", "canonical_value", "value_kind"]


class Context(enum.Enum):
    """The part of the knowledge an object belongs to (OA-WM-3)."""

    SELF = "SELF"
    SURROUNDINGS = "SURROUNDINGS"
    SYSTEM = "SYSTEM"


@dataclass(frozen=True, slots=True, kw_only=True)
class Ref:
    """A reference to another object, by name."""

    name: str

    def __post_init__(self) -> None:
        if not self.name or self.name != self.name.strip():
            raise ValueError(f"a reference needs a name without surrounding space: {self.name!r}")


Value = float | str | Ref
PacketKey = tuple[int, str, int, str, str, float, float]


def value_kind(value: Value) -> str:
    """Return `number`, `string` or `ref`: the element a value travels as (OA-WM-2)."""
    if isinstance(value, Ref):
        return "ref"
    return "string" if isinstance(value, str) else "number"


def canonical_value(value: Value) -> str:
    """Return the value as its wire text (numbers in Python's shortest round-trip form)."""
    if isinstance(value, Ref):
        return value.name
    if isinstance(value, str):
        return value
    return repr(float(value))


def _finite(name: str, number: float) -> None:
    if isinstance(number, bool) or not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, not {number!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class Packet:
    """One attribute value with its accuracy, confidence and observation time (OA-WM-2).

    `accuracy` is the possible deviation of the value (≥ 0), `confidence` the statistical
    confidence in its interpretation (0 to 1). `source`/`seq` identify the report that carried
    it (empty/0 for a class default).
    """

    value: Value
    accuracy: float = 0.0
    confidence: float = 1.0
    timestamp: int = 0
    source: str = ""
    seq: int = 0

    def __post_init__(self) -> None:
        if isinstance(self.value, (int, float)) and not isinstance(self.value, bool):
            _finite("value", self.value)
            object.__setattr__(self, "value", float(self.value))
        elif not isinstance(self.value, (str, Ref)):
            raise ValueError(f"a value is a number, a string or a Ref, not {self.value!r}")
        _finite("accuracy", self.accuracy)
        _finite("confidence", self.confidence)
        if self.accuracy < 0 or not 0 <= self.confidence <= 1:
            raise ValueError("accuracy must be ≥ 0 and confidence within 0 to 1")
        if isinstance(self.timestamp, bool) or self.timestamp < 0 or self.seq < 0:
            raise ValueError("timestamp and seq must be non-negative integers")

    @property
    def kind(self) -> str:
        """The value's kind: `number`, `string` or `ref`."""
        return value_kind(self.value)

    def key(self) -> PacketKey:
        """Return the last-writer-wins order key (OA-WM-6): the greatest key wins.

        (timestamp, source, seq) decide; kind, value, accuracy and confidence only break ties
        between packets that claim the same writer and sequence number, so that even a
        misbehaving writer cannot make replicas diverge.
        """
        text = canonical_value(self.value)
        return (
            self.timestamp,
            self.source,
            self.seq,
            self.kind,
            text,
            self.accuracy,
            self.confidence,
        )

    def newer_than(self, other: Packet | None) -> bool:
        """True when this packet replaces `other` under last-writer-wins (OA-WM-6)."""
        return other is None or self.key() > other.key()
