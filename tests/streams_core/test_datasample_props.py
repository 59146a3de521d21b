"""Properties of openair.protocol.datasample: encode/decode are inverse; decode refuses cleanly."""

from __future__ import annotations

import struct

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from openair.protocol.datasample import (
    BUILTIN_ID,
    BUILTIN_SEQ,
    BUILTIN_TIMESTAMP,
    DataSample,
    chunk_parts,
    decode_chunk,
    encode_chunk,
    encode_params,
    param_problem,
)
from openair.protocol.errors import ApiMisuseError, SampleInvalidError

# Pieces biased towards the separators' fragments, so that the edge rules get hit; the full
# separators are rarer, as they only ever make a pair unsafe.
_CHARS = st.characters(min_codepoint=1, max_codepoint=127)
_FRAGMENTS = st.sampled_from(["%", "sep", "equals", "%sep", "sep%", "%equals", "equals%"])
_PIECES = st.one_of(_CHARS, _CHARS, _FRAGMENTS, st.sampled_from(["%sep%", "%equals%"]))
_TEXT = st.lists(_PIECES, max_size=5).map("".join)
_EDGE_TEXT = st.lists(st.one_of(_CHARS, _FRAGMENTS), max_size=4).map("".join)
_ANY_TEXT = st.one_of(_EDGE_TEXT, _EDGE_TEXT, _EDGE_TEXT, _TEXT, st.text(max_size=4))


def _safe(pairs: list[tuple[str, str]]) -> bool:
    return all(param_problem(k, v) is None for k, v in pairs)


def _repair(pair: tuple[str, str]) -> tuple[str, str]:
    """Make a pair safe with the smallest edits, keeping the harmless separator fragments."""
    key, value = (t.replace("%sep%", "%sep_").replace("%equals%", "%equals_") for t in pair)
    key = key + "_" if not key or key.endswith(("%sep", "%equals")) else key
    value = "_" + value if value == "sep" or value.startswith("sep%") else value
    value = value + "_" if value.endswith("%sep") else value
    assert param_problem(key, value) is None, (key, value)
    return key, value


_SAFE_PAIR = st.tuples(_TEXT, _TEXT).map(_repair)
SAFE_PARAMS = st.lists(_SAFE_PAIR, max_size=5).map(tuple)


@settings(max_examples=100)
@given(payload=st.binary(max_size=300), params=SAFE_PARAMS)
def test_encode_decode_identity(payload: bytes, params: tuple[tuple[str, str], ...]) -> None:
    sample = DataSample(payload=payload, params=params)
    chunk = encode_chunk(sample)
    assert chunk[:4] == struct.pack("<I", len(payload)) and chunk[-1] == 0
    back = decode_chunk(chunk)
    assert back == sample
    assert bytes(back.payload) == payload and back.params == params
    assert encode_chunk(back) == chunk


@settings(max_examples=200)
@given(pairs=st.lists(st.tuples(_ANY_TEXT, _ANY_TEXT), min_size=1, max_size=3))
def test_encode_refuses_exactly_the_unsafe(pairs: list[tuple[str, str]]) -> None:
    """What encodes decodes back, also with a pair before or after it (as the stream adds)."""
    if not _safe(pairs):
        with pytest.raises(ApiMisuseError):
            encode_params(pairs)
        return
    for params in (pairs, [*pairs, ("z", "1")], [("z", "1"), *pairs]):
        assert decode_chunk(b"\0\0\0\0" + encode_params(params) + b"\0").params == tuple(params)


@settings(max_examples=200)
@given(key=_ANY_TEXT, value=_ANY_TEXT)
def test_one_safe_pair_decodes_back_between_neighbours(key: str, value: str) -> None:
    """A pair that param_problem accepts survives any position among other pairs."""
    if param_problem(key, value) is not None:
        with pytest.raises(ApiMisuseError):
            encode_params([(key, value)])
        return
    z = ("z", "1")
    for params in ([(key, value)], [(key, value), z], [z, (key, value)], [z, (key, value), z]):
        assert decode_chunk(b"\0\0\0\0" + encode_params(params) + b"\0").params == tuple(params)


@settings(max_examples=300)
@given(data=st.binary(max_size=64))
def test_decode_arbitrary_bytes(data: bytes) -> None:
    try:
        sample = decode_chunk(data)
    except SampleInvalidError as exc:
        assert exc.detail
        return
    # Whatever decodes is canonical: it encodes back to the very same bytes.
    assert encode_chunk(sample) == data


@settings(max_examples=150)
@given(
    payload=st.binary(max_size=40), params=SAFE_PARAMS, pos=st.integers(0), byte=st.integers(0, 255)
)
def test_decode_mutated_chunk(
    payload: bytes, params: tuple[tuple[str, str], ...], pos: int, byte: int
) -> None:
    chunk = bytearray(encode_chunk(DataSample(payload=payload, params=params)))
    chunk[pos % len(chunk)] = byte
    try:
        sample = decode_chunk(bytes(chunk))
    except SampleInvalidError:
        return
    assert encode_chunk(sample) == bytes(chunk)


@settings(max_examples=100)
@given(data=st.binary(max_size=64), cut=st.integers(0, 70))
def test_decode_truncated(data: bytes, cut: int) -> None:
    chunk = encode_chunk(DataSample(payload=data, params=(("k", "v"),)))
    assume(cut < len(chunk))
    with pytest.raises(SampleInvalidError):
        decode_chunk(chunk[:cut])


@given(
    params=SAFE_PARAMS,
    updates=st.lists(_SAFE_PAIR, max_size=3).map(dict),
)
def test_with_params_replaces_in_place_and_appends(
    params: tuple[tuple[str, str], ...], updates: dict[str, str]
) -> None:
    payload = memoryview(b"payload")
    sample = DataSample(payload=payload, params=params)
    out = sample.with_params(updates)
    assert out.payload is payload  # shared, not copied
    keys = [k for k, _ in out.params]
    for key, value in updates.items():
        assert keys.count(key) == 1 and out.param(key) == value
    # Keys not updated keep their order; updated keys sit where they first were.
    expected_order: list[str] = []
    for k, _ in params:
        if k not in updates or k not in expected_order:
            expected_order.append(k)
    expected_order += [k for k in updates if k not in expected_order]
    assert keys == expected_order


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("12", 12),
        ("0", 0),
        ("-5", -5),
        ("007", 7),
        ("", None),
        ("1.5", None),
        ("+3", None),
        (" 4", None),
        ("x", None),
        ("-", None),
        ("1_000", None),
        ("٣", None),
        ("9" * 5000, None),
    ],
)
def test_integer_properties(text: str, value: int | None) -> None:
    sample = DataSample(params=((BUILTIN_ID, text), (BUILTIN_TIMESTAMP, text), (BUILTIN_SEQ, text)))
    assert sample.id == sample.timestamp_ms == sample.seq == value


def test_absent_integer_properties() -> None:
    sample = DataSample(payload=b"x")
    assert sample.id is None and sample.timestamp_ms is None and sample.seq is None
    assert sample.param("k") is None


def test_param_returns_first_of_duplicates() -> None:
    assert DataSample(params=(("k", "a"), ("k", "b"))).param("k") == "a"


def test_equality_and_hash() -> None:
    a = DataSample(payload=b"abc", params=(("k", "v"),))
    b = DataSample(payload=memoryview(b"xabc")[1:], params=(("k", "v"),))
    assert a == b and b == a and not a.__ne__(b)
    assert a != DataSample(payload=b"abc")
    assert a != DataSample(payload=b"abd", params=(("k", "v"),))
    assert a != b"abc"
    with pytest.raises(TypeError):
        hash(a)


def test_repr_is_python() -> None:
    sample = DataSample(payload=memoryview(b"\x00ab"), params=(("k", "v"),))
    assert eval(repr(sample)) == sample  # our own repr, by design valid Python
    assert "<2000 bytes>" in repr(DataSample(payload=bytes(2000)))


def test_memoryview_of_other_format_is_seen_as_bytes() -> None:
    words = memoryview(b"\x01\x00\x02\x00").cast("H")
    sample = DataSample(payload=words)
    assert sample.size == 4 and encode_chunk(sample) == b"\x04\0\0\0\x01\x00\x02\x00\0"


def test_oversized_payload_refused() -> None:
    class Huge(bytes):
        def __len__(self) -> int:
            return 0x1_0000_0000

    with pytest.raises(ApiMisuseError):
        chunk_parts(DataSample(payload=Huge(b"")))


def test_decode_of_bytearray_and_views() -> None:
    chunk = encode_chunk(DataSample(payload=b"abc", params=(("k", "v"),)))
    framed = memoryview(b"HEAD" + chunk + b"TAIL")[4 : 4 + len(chunk)]
    sample = decode_chunk(framed)
    assert bytes(sample.payload) == b"abc" and sample.params == (("k", "v"),)
    assert decode_chunk(bytearray(chunk)) == sample  # type: ignore[arg-type]
