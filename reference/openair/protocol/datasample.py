"""Data samples and their binary chunks (spec 11.2; OA-STREAM-2, OA-STREAM-10).

Sans-I/O. A datasample chunk is: the payload length N (uint32, little-endian), N payload bytes,
the ASCII parameter string `key%equals%value%sep%key%equals%value…` (empty when there are none)
and one NUL byte. Decoding never copies the payload: the sample holds a memoryview slice of the
chunk. Encoding hands back the three parts so that a writer can send the payload without copying
it either.

Parsing splits the parameter string on `%sep%` first, then each pair on its first `%equals%`.
Because `%` is both the first and the last character of each separator, a key or value next to
a separator can run into it (a value `x%sep` followed by `%sep%` reads as `x` and a pair
`sep%…`). So besides holding neither separator, a key must not end with `%sep` or `%equals`
and a value must not be `sep`, start with `sep%` or end with `%sep`; with these rules decoding
is the exact inverse of encoding, and every decoded sample can be encoded again.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import ClassVar

from openair.protocol.errors import ApiMisuseError, SampleInvalidError

__all__ = [
    "BUILTIN_DURATION",
    "BUILTIN_HEIGHT",
    "BUILTIN_ID",
    "BUILTIN_NAME",
    "BUILTIN_SEQ",
    "BUILTIN_TIMESTAMP",
    "BUILTIN_TYPE",
    "BUILTIN_WIDTH",
    "DATASAMPLE_XML",
    "MAX_PAYLOAD",
    "SAMPLE_PARAM_EQ",
    "SAMPLE_PARAM_SEP",
    "DataSample",
    "chunk_parts",
    "decode_chunk",
    "decode_params",
    "encode_chunk",
    "encode_params",
    "param_problem",
]

SAMPLE_PARAM_SEP = "%sep%"
SAMPLE_PARAM_EQ = "%equals%"
DATASAMPLE_XML = "<datasample/>"
MAX_PAYLOAD = 0xFFFFFFFF

BUILTIN_ID = "builtin:id"
BUILTIN_TIMESTAMP = "builtin:timestamp"
BUILTIN_TYPE = "builtin:type"
BUILTIN_DURATION = "builtin:duration"
BUILTIN_NAME = "builtin:name"
BUILTIN_WIDTH = "builtin:width"
BUILTIN_HEIGHT = "builtin:height"
BUILTIN_SEQ = "builtin:seq"  # kit: the writer's sequence number (OA-XSTREAM-8)

_LENGTH = struct.Struct("<I")
_NUL = b"\x00"
_REPR_MAX = 1024  # longer payloads are summarised in repr()


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class DataSample:
    """One data sample: payload bytes and ordered text parameters (OA-STREAM-1).

    Equality compares the payload bytes and the parameters; a sample is not hashable (its
    payload may be a memoryview). A memoryview payload of another format is viewed as bytes.
    """

    payload: bytes | memoryview = b""
    params: tuple[tuple[str, str], ...] = ()

    __hash__: ClassVar[None] = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        payload = self.payload
        if isinstance(payload, memoryview) and (payload.format != "B" or payload.ndim != 1):
            flat = payload.cast("B") if payload.c_contiguous else memoryview(payload.tobytes())
            object.__setattr__(self, "payload", flat)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DataSample):
            return NotImplemented
        return self.params == other.params and self.payload == other.payload

    def __repr__(self) -> str:
        size = len(self.payload)
        shown = repr(bytes(self.payload)) if size <= _REPR_MAX else f"<{size} bytes>"
        return f"DataSample(payload={shown}, params={self.params!r})"

    @property
    def size(self) -> int:
        """Return the payload length in bytes."""
        return len(self.payload)

    def param(self, key: str) -> str | None:
        """Return the value of the first parameter named `key`, or None."""
        for k, v in self.params:
            if k == key:
                return v
        return None

    def _int_param(self, key: str) -> int | None:
        value = self.param(key)
        if value is None:
            return None
        digits = value[1:] if value[:1] == "-" else value
        if not (digits.isascii() and digits.isdigit()):
            return None
        try:
            return int(value)
        except ValueError:  # more digits than Python converts
            return None

    @property
    def id(self) -> int | None:
        """Return `builtin:id` as an integer, or None when absent or not an integer."""
        return self._int_param(BUILTIN_ID)

    @property
    def timestamp_ms(self) -> int | None:
        """Return `builtin:timestamp` (ms since the epoch), or None if absent or not an integer."""
        return self._int_param(BUILTIN_TIMESTAMP)

    @property
    def seq(self) -> int | None:
        """Return `builtin:seq`, or None when absent or not an integer."""
        return self._int_param(BUILTIN_SEQ)

    def with_params(self, updates: Mapping[str, str]) -> DataSample:
        """Return a sample with `updates` applied, sharing this sample's payload (no copy).

        An updated key keeps the place of its first occurrence (later duplicates of it are
        removed); new keys are appended at the end in the mapping's order.
        """
        if not updates:
            return self
        out: list[tuple[str, str]] = []
        done: set[str] = set()
        for k, v in self.params:
            if k in updates:
                if k not in done:
                    out.append((k, updates[k]))
                    done.add(k)
            else:
                out.append((k, v))
        out.extend((k, v) for k, v in updates.items() if k not in done)
        return DataSample(payload=self.payload, params=tuple(out))


def param_problem(key: str, value: str) -> str | None:
    """Return why (`key`, `value`) cannot be a sample parameter, or None if it can (OA-STREAM-2)."""
    if not key:
        return "empty key"
    for text, what in ((key, "key"), (value, "value")):
        if not text.isascii():
            return f"{what} {text!r} is not ASCII"
        if "\x00" in text:
            return f"{what} {text!r} holds a NUL"
        if SAMPLE_PARAM_SEP in text or SAMPLE_PARAM_EQ in text:
            return f"{what} {text!r} holds a separator (%sep% or %equals%)"
    # A `%` at an edge would run into the separator beside it (module docstring).
    if key.endswith(("%sep", "%equals")):
        return f"key {key!r} ends with '%sep' or '%equals'"
    # "%equals%" + value + "%sep%" must hold "%sep%" only at its end.
    if value == "sep" or value.startswith("sep%") or value.endswith("%sep"):
        return f"value {value!r} is 'sep', starts with 'sep%' or ends with '%sep'"
    return None


def encode_params(params: Iterable[tuple[str, str]]) -> bytes:
    """Return the ASCII parameter string of `params`, without the NUL; ApiMisuseError if invalid."""
    pairs: list[str] = []
    for key, value in params:
        problem = param_problem(key, value)  # OA-STREAM-2
        if problem is not None:
            raise ApiMisuseError(f"sample parameter: {problem}")
        pairs.append(f"{key}{SAMPLE_PARAM_EQ}{value}")
    return SAMPLE_PARAM_SEP.join(pairs).encode("ascii")


def decode_params(
    data: bytes | memoryview, *, max_params: int = 4096
) -> tuple[tuple[str, str], ...]:
    """Return the pairs of a parameter string (without the NUL); SampleInvalidError if malformed."""
    try:
        text = str(data, "ascii")
    except UnicodeDecodeError:  # OA-STREAM-10: parameters must be ASCII
        raise SampleInvalidError("sample parameters are not ASCII") from None
    if not text:
        return ()
    if "\x00" in text:  # OA-STREAM-2: one NUL, at the very end
        raise SampleInvalidError("sample parameters hold a NUL before the last byte")
    if text.count(SAMPLE_PARAM_SEP) >= max_params:
        raise SampleInvalidError(f"more than {max_params} sample parameters")
    return tuple(_decode_pair(pair) for pair in text.split(SAMPLE_PARAM_SEP))


def _decode_pair(pair: str) -> tuple[str, str]:
    key, eq, value = pair.partition(SAMPLE_PARAM_EQ)
    if not eq:  # OA-STREAM-10: a list of key%equals%value pairs
        raise SampleInvalidError(f"sample parameter {pair[:80]!r} has no %equals%")
    problem = param_problem(key, value)  # OA-STREAM-10
    if problem is not None:
        raise SampleInvalidError(f"sample parameter: {problem}")
    return key, value


def chunk_parts(sample: DataSample) -> tuple[bytes, bytes | memoryview, bytes]:
    """Return (length, payload, parameters + NUL): the chunk of `sample` in three parts.

    The payload part is the sample's own object, so writing the parts copies no payload.
    """
    size = len(sample.payload)
    if size > MAX_PAYLOAD:  # OA-STREAM-2: the length is an unsigned 32-bit integer
        raise ApiMisuseError(f"sample payload of {size} bytes exceeds {MAX_PAYLOAD} bytes")
    return _LENGTH.pack(size), sample.payload, encode_params(sample.params) + _NUL


def encode_chunk(sample: DataSample) -> bytes:
    """Return the datasample chunk of `sample` (OA-STREAM-2)."""
    return b"".join(chunk_parts(sample))


def decode_chunk(chunk: bytes | memoryview, *, max_params: int = 4096) -> DataSample:
    """Return the sample of a datasample chunk; the payload is a memoryview slice of `chunk`.

    Raises SampleInvalidError for a chunk shorter than 5 bytes or than 5 + N, one whose last
    byte is not NUL, or whose parameters are not ASCII `key%equals%value` pairs (OA-STREAM-10).
    """
    view = chunk if isinstance(chunk, memoryview) else memoryview(chunk)
    if view.format != "B" or view.ndim != 1:
        view = view.cast("B")
    total = len(view)
    if total < 5:  # OA-STREAM-10: length field plus the NUL
        raise SampleInvalidError(f"datasample chunk of {total} bytes is shorter than 5 bytes")
    (size,) = _LENGTH.unpack_from(view)
    if size > total - 5:  # OA-STREAM-10: size less than 5 + N
        raise SampleInvalidError(
            f"datasample chunk of {total} bytes is too short for its payload length {size}"
        )
    if view[total - 1] != 0:  # OA-STREAM-10: last byte NUL
        raise SampleInvalidError("datasample chunk does not end with a NUL byte")
    params = decode_params(view[4 + size : total - 1], max_params=max_params)
    return DataSample(payload=view[4 : 4 + size], params=params)
