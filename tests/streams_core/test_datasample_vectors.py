"""The shared datasample chunk vectors (spec/vectors/samples) against `protocol.datasample`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from openair.protocol.datasample import (
    DataSample,
    chunk_parts,
    decode_chunk,
    encode_chunk,
    encode_params,
)
from openair.protocol.errors import OpenAIRError, error_for

VECTORS = Path(__file__).resolve().parents[2] / "spec" / "vectors"
TABLE: dict[str, Any] = json.loads((VECTORS / "samples" / "chunks.json").read_text("ascii"))


def _ids(rows: list[dict[str, Any]]) -> list[str]:
    return [row["name"] for row in rows]


def _params(row: dict[str, Any]) -> tuple[tuple[str, str], ...]:
    return tuple((k, v) for k, v in row["params"])


def test_table_shape() -> None:
    assert TABLE["format"] == "openair-sample-vectors/1"
    names = _ids(TABLE["valid"]) + _ids(TABLE["invalid"]) + _ids(TABLE["unencodable"])
    assert len(names) == len(set(names))
    assert {row["error"] for row in TABLE["invalid"]} == {"SAMPLE_INVALID"}


@pytest.mark.parametrize("row", TABLE["valid"], ids=_ids(TABLE["valid"]))
def test_valid_chunk_decodes(row: dict[str, Any]) -> None:
    chunk = bytes.fromhex(row["chunk"])
    sample = decode_chunk(chunk)
    assert bytes(sample.payload) == bytes.fromhex(row["payload"])
    assert sample.params == _params(row)
    # Zero copy: the payload is a view into the chunk itself.
    assert isinstance(sample.payload, memoryview)
    assert sample.payload.obj is chunk


@pytest.mark.parametrize("row", TABLE["valid"], ids=_ids(TABLE["valid"]))
def test_valid_chunk_encodes_back(row: dict[str, Any]) -> None:
    sample = DataSample(payload=bytes.fromhex(row["payload"]), params=_params(row))
    assert encode_chunk(sample).hex() == row["chunk"]
    length, payload, tail = chunk_parts(sample)
    assert payload is sample.payload
    assert (length + payload + tail).hex() == row["chunk"]


@pytest.mark.parametrize("row", TABLE["invalid"], ids=_ids(TABLE["invalid"]))
def test_invalid_chunk_refused(row: dict[str, Any]) -> None:
    expected = error_for(row["error"])
    with pytest.raises(OpenAIRError) as info:
        decode_chunk(bytes.fromhex(row["chunk"]), max_params=row.get("max_params", 4096))
    assert type(info.value) is expected
    assert info.value.detail  # a clear detail for the DATA_NOT_ACCEPTED content


@pytest.mark.parametrize("row", TABLE["invalid"], ids=_ids(TABLE["invalid"]))
def test_invalid_chunk_refused_as_memoryview(row: dict[str, Any]) -> None:
    with pytest.raises(error_for(row["error"])):
        decode_chunk(
            memoryview(bytes.fromhex(row["chunk"])), max_params=row.get("max_params", 4096)
        )


@pytest.mark.parametrize("row", TABLE["unencodable"], ids=_ids(TABLE["unencodable"]))
def test_unencodable_params_refused(row: dict[str, Any]) -> None:
    expected = error_for(row["error"])
    with pytest.raises(expected):
        encode_params(_params(row))
    with pytest.raises(expected):
        encode_chunk(DataSample(payload=b"x", params=_params(row)))


def test_binarym_vector_holds_the_same_chunk() -> None:
    """The frames vector `binarym-datasample.bin` carries the `binarym-sample` row's chunk."""
    frame = (VECTORS / "frames" / "binarym-datasample.bin").read_bytes()
    assert frame[:8] == b"BinaryM\x00"
    length = int.from_bytes(frame[8:12], "little")
    row = next(r for r in TABLE["valid"] if r["name"] == "binarym-sample")
    assert frame[12 : 12 + length].hex() == row["chunk"]


def test_max_params_boundary() -> None:
    chunk = encode_chunk(DataSample(payload=b"", params=(("a", "1"), ("b", "2"))))
    assert len(decode_chunk(chunk, max_params=2).params) == 2
    with pytest.raises(error_for("SAMPLE_INVALID")):
        decode_chunk(chunk, max_params=1)


def test_spec_example_chunk_sizes() -> None:
    """The examples of spec 11.2 and 11.6 give the chunk sizes 29 and 97 bytes."""
    rows = {r["name"]: r for r in TABLE["valid"]}
    assert len(bytes.fromhex(rows["spec-11-2-example"]["chunk"])) == 29
    assert len(bytes.fromhex(rows["spec-11-6-pushed"]["chunk"])) == 97
