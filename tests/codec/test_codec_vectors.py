"""Run every case of spec/vectors/messages against the codec.

For each case: decoding gives the expected fields (or exactly the expected error), encoding the
decoded message gives the canonical file byte for byte, the canonical file decodes to the same
message and re-encodes to itself, and the canonical file validates against schemas/message.xsd
(unless the manifest says why it cannot).
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path
from typing import Any

import pytest
from lxml import etree
from vector_fields import check_fields, first_nested

from openair.catalogue import load_catalogue
from openair.protocol.codec import decode_message, encode_message
from openair.protocol.errors import error_for
from openair.protocol.xmlsafe import parse_xml

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "spec" / "vectors" / "messages"
MANIFEST: dict[str, Any] = json.loads((VECTORS / "manifest.json").read_text(encoding="utf-8"))
CASES: list[dict[str, Any]] = MANIFEST["cases"]
VALID = [c for c in CASES if "fields" in c["expected"]]
INVALID = [c for c in CASES if "error" in c["expected"]]


def _ids(cases: list[dict[str, Any]]) -> list[str]:
    return [c["name"] for c in cases]


@cache
def _schema() -> etree.XMLSchema:
    parser = etree.XMLParser(resolve_entities=False, no_network=True)
    return etree.XMLSchema(etree.parse(str(ROOT / "schemas" / "message.xsd"), parser))


def _source(case: dict[str, Any]) -> bytes:
    return (VECTORS / str(case["file"])).read_bytes()


def _chunks(case: dict[str, Any]) -> tuple[bytes, ...]:
    return tuple(bytes.fromhex(h) for h in case.get("chunks", ()))


def test_manifest_is_well_formed() -> None:
    assert MANIFEST["format"] == "openair-message-vectors/1"
    names = [c["name"] for c in CASES]
    assert len(names) == len(set(names))
    referenced = {c["file"] for c in CASES} | {c["canonical"] for c in CASES if "canonical" in c}
    on_disk = {p.name for p in VECTORS.glob("*.xml")}
    assert referenced == on_disk  # no missing and no orphaned files
    for case in CASES:
        assert ("canonical" in case) == ("fields" in case["expected"]), case["name"]


@pytest.mark.parametrize("case", [c for c in CASES if "origin" in c], ids=lambda c: c["name"])
def test_captured_frames_have_their_captured_length(case: dict[str, Any]) -> None:
    match = re.search(r"xmllen=(\d+)$", case["origin"])
    assert match is not None and case["origin"].startswith("psyclone-wire/")
    assert len(_source(case)) == int(match.group(1))


def test_manifest_cites_known_requirements() -> None:
    known = load_catalogue()
    cited = {req for case in CASES for req in case["requirements"]}
    assert cited <= set(known), sorted(cited - set(known))


@pytest.mark.parametrize("case", VALID, ids=_ids(VALID))
def test_decode_gives_fields(case: dict[str, Any]) -> None:
    msg = decode_message(_source(case), _chunks(case))
    check_fields(msg, case["expected"]["fields"])
    if "nested" in case["expected"]:
        check_fields(first_nested(msg), case["expected"]["nested"])


@pytest.mark.parametrize("case", INVALID, ids=_ids(INVALID))
def test_decode_gives_error(case: dict[str, Any]) -> None:
    expected = error_for(case["expected"]["error"])
    with pytest.raises(expected) as info:
        decode_message(_source(case), _chunks(case))
    assert type(info.value) is expected
    assert info.value.detail  # every error says what was wrong


@pytest.mark.parametrize("case", VALID, ids=_ids(VALID))
def test_encode_gives_canonical_bytes(case: dict[str, Any]) -> None:
    canonical = (VECTORS / case["canonical"]).read_bytes()
    msg = decode_message(_source(case), _chunks(case))
    assert encode_message(msg) == canonical
    again = decode_message(canonical, _chunks(case))
    assert again == msg
    assert encode_message(again) == canonical


@pytest.mark.parametrize("case", VALID, ids=_ids(VALID))
def test_canonical_file_against_schema(case: dict[str, Any]) -> None:
    canonical = parse_xml((VECTORS / case["canonical"]).read_bytes())
    valid = _schema().validate(canonical)
    if case.get("xsd_valid", True):
        assert valid, str(_schema().error_log)
    else:  # the manifest explains why; a change here must update the explanation
        assert case["xsd_note"]
        assert not valid
