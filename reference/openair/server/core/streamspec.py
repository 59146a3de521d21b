"""What a stream is and holds: its configuration, stored samples, alarms (spec 11.1, 11.7).

`StreamSpec` reads a configured `<stream>` (limits in MiB and samples, a typed stream's type
and alarm whiteboard); `StoredSample`, `Alarm` and `AddResult` are the values
`openair.server.core.streams.Stream` stores and returns. Sans-I/O.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field

from openair.protocol.datasample import DataSample
from openair.protocol.errors import ApiMisuseError, ContentInvalidError, TypeInvalidError
from openair.protocol.types import validate_type
from openair.server.core.config import StreamConfig

__all__ = [
    "ALARM_KINDS",
    "ALARM_TYPE_PREFIX",
    "DEFAULT_IDLE_MS",
    "AddResult",
    "Alarm",
    "StoredSample",
    "StreamSpec",
]

_MIB = 1_048_576
ALARM_TYPE_PREFIX = "AIR.Stream.Alarm."
ALARM_KINDS = ("Started", "Idle", "SoftLimit", "HardLimit", "Gap")
DEFAULT_IDLE_MS = 5000


@dataclass(frozen=True, slots=True, kw_only=True)
class StreamSpec:
    """A stream's configuration: name, limits and, for a typed stream, its type (spec 11.7).

    `hardsize` is in payload bytes; `hardcount` 0 means no count limit. `softsize` and
    `softcount` None (or a `softcount` of 0) mean "equal to the hard limit". `maxsize` and
    `maxcount` are what GET_INFO reports as such (None: the hard limits).
    """

    name: str
    whiteboard: str
    type: str | None = None
    hardsize: int
    hardcount: int = 0
    softsize: int | None = None
    softcount: int | None = None
    idle_ms: int = DEFAULT_IDLE_MS
    alarms: str = ""
    maxsize: int | None = None
    maxcount: int | None = None

    def __post_init__(self) -> None:
        problem = _limits_problem(self)
        if problem is not None:
            raise ApiMisuseError(f"stream {self.name!r}: {problem}")

    @property
    def typed(self) -> bool:
        """Return whether this is a typed stream (extension `typed-streams`)."""
        return self.type is not None

    @property
    def soft_size(self) -> int:
        """Return the effective soft size limit in bytes (the hard one when none is set)."""
        return self.hardsize if self.softsize is None else self.softsize

    @property
    def soft_count(self) -> int:
        """Return the effective soft count limit (0: none; the hard one when none is set)."""
        return self.softcount if self.softcount else self.hardcount

    @property
    def alarm_whiteboard(self) -> str:
        """Return the whiteboard that receives this stream's alarms."""
        return self.alarms or self.whiteboard

    @classmethod
    def from_config(
        cls,
        cfg: StreamConfig,
        whiteboard: str,
        *,
        typed_streams: bool,
        whiteboards: Collection[str] | None = None,
    ) -> StreamSpec:
        """Return the spec of a configured `<stream>`; ContentInvalidError for bad values.

        Without `typed_streams`, or without a `type` attribute, the typed attributes are
        ignored and the stream is an untyped ring (OA-STREAM-9). When `whiteboards` is given,
        an `alarms` attribute must name one of them (spec 11.7). Type uniqueness is the
        caller's to check (OA-XSTREAM-1).
        """
        shown = f"stream {cfg.name!r}"
        if not math.isfinite(cfg.maxsize) or cfg.maxsize < 0:
            raise ContentInvalidError(f"{shown}: maxsize {cfg.maxsize!r} is not a size")
        if cfg.maxcount < 0:
            raise ContentInvalidError(f"{shown}: maxcount {cfg.maxcount} is negative")
        maxsize = int(cfg.maxsize * _MIB)  # OA-STREAM-9: units of 1 048 576 bytes
        attrs = dict(cfg.attributes)
        if not typed_streams or "type" not in attrs:
            return cls(
                name=cfg.name, whiteboard=whiteboard, hardsize=maxsize, hardcount=cfg.maxcount
            )
        try:
            type_ = validate_type(attrs["type"])  # OA-XSTREAM-1
        except TypeInvalidError as exc:
            raise ContentInvalidError(f"{shown}: {exc.detail}") from None
        hardsize = _int_attr(attrs, "hardsize", shown, positive=True)
        hardcount = _int_attr(attrs, "hardcount", shown)
        idle = _int_attr(attrs, "idle", shown)
        alarms = attrs.get("alarms", "")
        if alarms and whiteboards is not None and alarms not in whiteboards:
            raise ContentInvalidError(f"{shown}: alarms {alarms!r} names no whiteboard")
        try:
            return cls(
                name=cfg.name,
                whiteboard=whiteboard,
                type=type_,
                hardsize=maxsize if hardsize is None else hardsize,
                hardcount=cfg.maxcount if hardcount is None else hardcount,
                softsize=_int_attr(attrs, "softsize", shown, positive=True),
                softcount=_int_attr(attrs, "softcount", shown),
                idle_ms=DEFAULT_IDLE_MS if idle is None else idle,
                alarms=alarms,
                maxsize=maxsize,
                maxcount=cfg.maxcount,
            )
        except ApiMisuseError as exc:  # soft above hard: a configuration error
            raise ContentInvalidError(exc.detail) from None


def _int_attr(attrs: dict[str, str], key: str, shown: str, *, positive: bool = False) -> int | None:
    """Return attribute `key` as a decimal integer (>= 0, or > 0), or None when absent."""
    text = attrs.get(key)
    if text is None:
        return None
    value = text.strip()
    if (
        not (value.isascii() and value.isdigit())
        or len(value) > 19
        or (positive and not int(value))
    ):
        what = "a positive" if positive else "a non-negative"
        raise ContentInvalidError(f"{shown}: {key} {text!r} is not {what} integer")
    return int(value)


def _limits_problem(spec: StreamSpec) -> str | None:
    """Return why the limits of `spec` do not hold together, or None."""
    for what in ("hardsize", "hardcount", "softsize", "softcount", "idle_ms"):
        value = getattr(spec, what)
        if value is not None and value < 0:
            return f"{what} {value} is negative"
    if spec.softsize is not None and spec.softsize > spec.hardsize:
        return f"softsize {spec.softsize} is larger than hardsize {spec.hardsize}"
    if spec.softcount and spec.hardcount and spec.softcount > spec.hardcount:
        return f"softcount {spec.softcount} is larger than hardcount {spec.hardcount}"
    return None


@dataclass(frozen=True, slots=True, kw_only=True)
class StoredSample:
    """A sample a stream holds: its id, timestamp and the chunk parts, computed once."""

    id: int
    timestamp_ms: int
    received_ns: int
    sample: DataSample  # carries builtin:id and builtin:timestamp as set by the stream
    size: int  # payload bytes
    parts: tuple[bytes, bytes | memoryview, bytes] = field(repr=False)
    # The whole chunk, joined once when the sample was stored; `sample.payload` and `parts[1]`
    # are views into it, so every reader and subscriber is sent these bytes without a copy.
    wire: bytes = field(default=b"", repr=False)

    def chunk(self) -> bytes:
        """Return the datasample chunk (the stored bytes; no copy when `wire` is set)."""
        return self.wire or b"".join(self.parts)


@dataclass(frozen=True, slots=True, kw_only=True)
class Alarm:
    """An alarm a typed stream raises; the router posts it (OA-XSTREAM-6).

    `entries` is the `<dictionary>` content: `stream`, `streamtype`, `time` (ms), then the
    entries of the kind (STREAMS.md section 3).
    """

    kind: str
    stream: str
    whiteboard: str
    entries: tuple[tuple[str, str], ...]

    @property
    def type(self) -> str:
        """Return the post's message type, `AIR.Stream.Alarm.<Kind>`."""
        return ALARM_TYPE_PREFIX + self.kind


@dataclass(frozen=True, slots=True, kw_only=True)
class AddResult:
    """What one `Stream.add` did.

    `stored` holds every sample added, in id order, including any that the limits dropped
    again in the same add; `dropped` counts the samples the limits dropped (old or new).
    """

    stored: tuple[StoredSample, ...]
    alarms: tuple[Alarm, ...] = ()
    dropped: int = 0
