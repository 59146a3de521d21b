"""Run every case of spec/vectors/legacy: what Psyclone 1.1.7 writes, read as a client reads it.

Each case decodes (priorities out of range clamped, OA-MSG-19) to the expected fields, its first
nested stored copy to the expected nested fields, the fast path and the lxml path agree, and the
strict reading of a server (OA-MSG-6) gives the error the manifest names or the same message.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from vector_fields import check_fields, first_nested

from openair.catalogue import load_catalogue
from openair.protocol.codec import decode_message, decode_with_lxml, encode_message
from openair.protocol.errors import MessageInvalidError, error_for
from openair.protocol.fastcodec import fast_decode
from openair.protocol.wakeup import parse_wakeup

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "spec" / "vectors" / "legacy"
MANIFEST: dict[str, Any] = json.loads((VECTORS / "manifest.json").read_text(encoding="utf-8"))
CASES: list[dict[str, Any]] = MANIFEST["cases"]


def _source(case: dict[str, Any]) -> bytes:
    return (VECTORS / str(case["file"])).read_bytes()


def test_manifest_is_well_formed() -> None:
    assert MANIFEST["format"] == "openair-legacy-vectors/1"
    names = [c["name"] for c in CASES]
    assert len(names) == len(set(names))
    assert {c["file"] for c in CASES} == {p.name for p in VECTORS.glob("*.xml")}
    for case in CASES:
        assert case["origin"].startswith(("psyclone-observed-2.md section", "synthetic")), case
    cited = {req for case in CASES for req in case["requirements"]}
    assert cited <= set(load_catalogue()), sorted(cited - set(load_catalogue()))


@pytest.mark.parametrize("case", CASES, ids=lambda c: c["name"])
def test_client_reading_gives_fields(case: dict[str, Any]) -> None:
    msg = decode_message(_source(case), clamp_priority=True)
    check_fields(msg, case["expected"]["fields"])
    if "nested" in case["expected"]:
        check_fields(first_nested(msg), case["expected"]["nested"])


@pytest.mark.parametrize("case", CASES, ids=lambda c: c["name"])
def test_fast_path_agrees_with_lxml(case: dict[str, Any]) -> None:
    data = _source(case)
    reference = decode_with_lxml(data, clamp_priority=True)
    fast = fast_decode(data, clamp_priority=True)
    assert fast is None or fast == reference
    assert decode_message(data, clamp_priority=True) == reference
    # A writer stays strict and canonical: what was read is written back in range.
    assert decode_message(encode_message(reference)) == reference


@pytest.mark.parametrize("case", CASES, ids=lambda c: c["name"])
def test_strict_reading(case: dict[str, Any]) -> None:
    data = _source(case)
    if "strict" in case:
        expected = error_for(case["strict"]["error"])
        with pytest.raises(expected) as info:
            decode_message(data)
        assert type(info.value) is expected and "priority" in info.value.detail
    else:
        assert decode_message(data) == decode_message(data, clamp_priority=True)


@pytest.mark.parametrize(
    "case",
    [c for c in CASES if c["expected"]["fields"].get("type") == "AIR.Instruct.Wakeup"],
    ids=lambda c: c["name"],
)
def test_wakeups_parse_with_their_trigger(case: dict[str, Any]) -> None:
    msg = decode_message(_source(case))  # the wakeup's own envelope has no priority
    wakeup = parse_wakeup(msg)
    assert wakeup.trigger is not None
    check_fields(wakeup.trigger, case["expected"]["nested"])


@pytest.mark.parametrize(
    ("text", "clamped"),
    [("7.00", 6.999), ("7", 6.999), (" 99.5 ", 6.999), ("-0.50", 0.0), ("-0", 0.0), ("2.00", 2.0)],
)
def test_clamp_on_both_paths(text: str, clamped: float) -> None:
    canonical = f'<message priority="{text}"><type>A</type><id>i</id><from/><to/><cc/><stored/>'
    canonical += '<isresponse/><content language=""/></message>'
    general = f'<message priority="{text}">\n\t<type>A</type>\n\t<Zeta>z</Zeta>\n</message>'
    for xml in (canonical.encode(), general.encode()):
        assert decode_with_lxml(xml, clamp_priority=True).priority == clamped
        assert decode_message(xml, clamp_priority=True).priority == clamped
        fast = fast_decode(xml, clamp_priority=True)
        assert fast is not None and fast.priority == clamped  # both shapes take the fast path


@pytest.mark.parametrize("text", ["7.00", "6.9991", "-0.5"])
def test_a_server_still_refuses_a_post_out_of_range(text: str) -> None:
    xml = f'<message priority="{text}"><type>A</type><to>WB1</to></message>'.encode()
    with pytest.raises(MessageInvalidError):
        decode_message(xml)
    with pytest.raises(MessageInvalidError):
        decode_with_lxml(xml)
    assert fast_decode(xml) is None  # declined: the lxml path raises


@pytest.mark.parametrize("text", ["high", "1e3", "", "7,00"])
def test_clamping_never_accepts_a_non_number(text: str) -> None:
    xml = f'<message priority="{text}"><type>A</type></message>'.encode()
    with pytest.raises(MessageInvalidError):
        decode_message(xml, clamp_priority=True)
