"""OpenAIR time values (spec section 4).

A time travels as an element with `sec` (Unix seconds) and `msec` (0–999); the `usec` extension
adds microseconds within the millisecond (OA-TIME-5). The core never reads a clock: callers pass
`now` in, as nanoseconds from `time.time_ns()` or an equivalent.
"""

from __future__ import annotations

from dataclasses import dataclass

_MAX_SEC = 2**63 - 1
_MIN_SEC = -(2**63)


@dataclass(frozen=True, slots=True, kw_only=True, order=True)
class AirTime:
    """A point in time as OpenAIR carries it: seconds, milliseconds and optional microseconds."""

    sec: int
    msec: int = 0
    usec: int | None = None

    def __post_init__(self) -> None:
        # OA-TIME-1, OA-TIME-6: sec is a 64-bit signed integer, msec and usec are 0–999.
        if not _MIN_SEC <= self.sec <= _MAX_SEC:
            raise ValueError(f"sec out of 64-bit range: {self.sec}")
        if not 0 <= self.msec <= 999:
            raise ValueError(f"msec out of range 0-999: {self.msec}")
        if self.usec is not None and not 0 <= self.usec <= 999:
            raise ValueError(f"usec out of range 0-999: {self.usec}")

    @classmethod
    def from_ns(cls, ns: int, *, with_usec: bool = False) -> AirTime:
        """Build a time from nanoseconds since the epoch (e.g. `time.time_ns()`)."""
        sec, rest = divmod(ns, 1_000_000_000)
        msec, rest = divmod(rest, 1_000_000)
        return cls(sec=sec, msec=msec, usec=rest // 1000 if with_usec else None)

    @classmethod
    def from_ms(cls, ms: int) -> AirTime:
        """Build a time from milliseconds since the epoch."""
        sec, msec = divmod(ms, 1000)
        return cls(sec=sec, msec=msec)

    @property
    def ms(self) -> int:
        """Milliseconds since the epoch (microseconds dropped)."""
        return self.sec * 1000 + self.msec

    @property
    def us(self) -> int:
        """Microseconds since the epoch (0 µs when `usec` is absent)."""
        return self.ms * 1000 + (self.usec or 0)

    def __str__(self) -> str:
        frac = f"{self.msec:03d}" + (f"{self.usec:03d}" if self.usec is not None else "")
        return f"{self.sec}.{frac}"
