"""The shared frame vectors (spec/vectors/frames) against the reference FrameReader.

Each vector is fed whole, one byte at a time, in random splits, and whole with `feed_eof` before
the frames are taken: every way must give the manifest's frames and the same ending.
"""

from __future__ import annotations

import hashlib
import json
import random
import subprocess
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from openair.catalogue import load_catalogue
from openair.protocol.errors import ERRORS, RemoteProtocolError
from openair.protocol.framing import Frame, FrameLimits, FrameReader, FrameTag

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "spec" / "vectors" / "frames"
MANIFEST: dict[str, Any] = json.loads((FOLDER / "manifest.json").read_text(encoding="utf-8"))
CASES: list[dict[str, Any]] = MANIFEST["cases"]
ENDINGS = {"ok": "ok", "truncated": "FRAME_TRUNCATED"}


@dataclass
class Outcome:
    """What a reader produced from one vector."""

    frames: list[dict[str, Any]]
    end: str  # "ok" or the error's condition name
    fed: int  # bytes fed when the reader reported the error (all of them when "ok")
    reader: FrameReader


def describe(frame: Frame) -> dict[str, Any]:
    """Return a frame in the manifest's form."""
    return {
        "tag": frame.tag.value,
        "xml_len": len(frame.xml),
        "xml_sha256": hashlib.sha256(frame.xml).hexdigest(),
        "chunks": [len(c) for c in frame.chunks],
        "chunks_sha256": [hashlib.sha256(c).hexdigest() for c in frame.chunks],
    }


def limits_of(case: dict[str, Any]) -> FrameLimits:
    lim = case.get("limits", MANIFEST["default_limits"])
    return FrameLimits(max_xml=lim["max_xml"], max_binary=lim["max_binary"])


def run(pieces: Iterable[bytes], limits: FrameLimits, *, drain: bool = True) -> Outcome:
    """Feed `pieces` (taking frames after each unless `drain` is False), then end the stream."""
    reader = FrameReader(limits)
    frames: list[dict[str, Any]] = []
    fed = 0
    try:
        for piece in pieces:
            reader.feed(piece)
            fed += len(piece)
            while drain and (frame := reader.next_frame()) is not None:
                frames.append(describe(frame))
        reader.feed_eof()
        while (frame := reader.next_frame()) is not None:
            frames.append(describe(frame))
    except RemoteProtocolError as exc:
        return Outcome(frames, exc.name, fed, reader)
    return Outcome(frames, "ok", fed, reader)


def random_pieces(data: bytes, seed: str) -> Iterator[bytes]:
    rng = random.Random(seed)
    at = 0
    while at < len(data):
        size = rng.choice((1, 2, 3, 5, 8, 11, 12, 13, 64, 300, 4096))
        yield data[at : at + size]
        at += size


def data_of(case: dict[str, Any]) -> bytes:
    return (FOLDER / str(case["file"])).read_bytes()


def expected_end(case: dict[str, Any]) -> str:
    exp = case["expected"]
    return str(exp["error"]) if "error" in exp else ENDINGS[exp["then"]]


def check(case: dict[str, Any], got: Outcome) -> None:
    exp = case["expected"]
    assert got.end == expected_end(case)
    if "error" in exp:
        assert len(got.frames) == exp["after_frames"]
        if "frames" in exp:
            assert got.frames == exp["frames"]
    else:
        assert got.frames == exp["frames"]


def ids(case: dict[str, Any]) -> str:
    return str(case["name"])


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_whole(case: dict[str, Any]) -> None:
    check(case, run([data_of(case)], limits_of(case)))


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_byte_at_a_time(case: dict[str, Any]) -> None:
    data = data_of(case)
    got = run((data[i : i + 1] for i in range(len(data))), limits_of(case))
    check(case, got)
    exp = case["expected"]
    if "error_by" in exp:
        # The error is reported no later than the manifest says (OA-FRAME-6, OA-FRAME-7); only
        # an unknown tag may be seen earlier, as soon as the bytes cannot begin a tag.
        assert got.fed <= exp["error_by"]
        if exp["error"] != "FRAME_UNKNOWN_TAG":
            assert got.fed == exp["error_by"]


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("case", CASES, ids=ids)
def test_random_splits(case: dict[str, Any], seed: int) -> None:
    data = data_of(case)
    check(case, run(random_pieces(data, f"{case['name']}/{seed}"), limits_of(case)))


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_eof_before_taking_frames(case: dict[str, Any]) -> None:
    # Complete frames still buffered at feed_eof stay available; the ending comes after them.
    check(case, run([data_of(case)], limits_of(case), drain=False))


@pytest.mark.parametrize("case", [c for c in CASES if expected_end(c) != "ok"], ids=ids)
def test_error_is_sticky(case: dict[str, Any]) -> None:
    got = run([data_of(case)], limits_of(case))
    reader = got.reader
    first = reader.error
    assert first is not None and first.name == expected_end(case)
    assert reader.buffered == 0 and not reader.in_frame  # OA-FRAME-8: the partial frame is gone
    for attempt in (reader.next_frame, lambda: reader.feed(b"Message\0"), reader.feed_eof):
        with pytest.raises(RemoteProtocolError) as info:
            attempt()
        assert info.value is first  # OA-FRAME-9


def test_manifest_shape() -> None:
    assert MANIFEST["format"] == "openair-frame-vectors/1"
    names = [c["name"] for c in CASES]
    assert len(names) == len(set(names))
    listed = {c["file"] for c in CASES}
    assert listed == {p.name for p in FOLDER.glob("*.bin")}
    catalogue = load_catalogue()
    tags = {t.value for t in FrameTag}
    for case in CASES:
        assert case["description"] and case["requirements"], case["name"]
        assert set(case["requirements"]) <= set(catalogue), case["name"]
        exp = case["expected"]
        assert ("error" in exp) != ("then" in exp), case["name"]
        if "error" in exp:
            assert exp["error"] in ERRORS and ERRORS[exp["error"]].code // 100 == 1
        for frame in exp.get("frames", []):
            assert frame["tag"] in tags


def test_every_ending_and_tag_is_covered() -> None:
    ends = {expected_end(c) for c in CASES}
    assert ends == {
        "ok",
        "FRAME_TRUNCATED",
        "FRAME_UNKNOWN_TAG",
        "FRAME_TOO_LARGE",
        "BINARY_TOO_LARGE",
        "BINARY_SIZES_INVALID",
    }
    tags = {f["tag"] for c in CASES for f in c["expected"].get("frames", [])}
    assert tags == {t.value for t in FrameTag}
    assert any(c["source"].startswith("psyclone-wire/") for c in CASES)


def test_generator_is_up_to_date() -> None:
    # The .bin files and the manifest are exactly what tools/gen_frame_vectors.py writes.
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "gen_frame_vectors.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
