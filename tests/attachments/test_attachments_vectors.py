"""The attachment vectors (spec/vectors/attachments): nested chunks and the content version."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from openair.protocol._errors_base import OpenAIRError
from openair.protocol.attachments import parse_results
from openair.protocol.codec import decode_message, encode_message
from openair.protocol.message import Message
from openair.protocol.wakeup import parse_wakeup

ROOT = Path(__file__).resolve().parents[2] / "spec" / "vectors" / "attachments"
CASES: list[dict[str, Any]] = json.loads((ROOT / "manifest.json").read_text())["cases"]


def _frame(case: dict[str, Any]) -> Message:
    chunks = tuple(bytes.fromhex(h) for h in case.get("chunks", ()))
    return decode_message((ROOT / case["file"]).read_bytes(), chunks)


def _attachments(case: dict[str, Any], msg: Message) -> list[list[Any]]:
    if case["kind"] == "wakeup":
        wakeup = parse_wakeup(msg)
        assert wakeup.trigger is not None
        copies = [wakeup.trigger, *wakeup.retrieved]
    else:
        copies = list(parse_results(msg))
    return [[m.id, [c.hex() for c in m.binary]] for m in copies]


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_attachment_vector(case: dict[str, Any]) -> None:
    expected = case["expected"]
    msg = _frame(case)
    if "error" in expected:
        with pytest.raises(OpenAIRError) as info:
            _attachments(case, msg)
        assert info.value.name == expected["error"]
        return
    if case["kind"] == "message":
        got = {"language": msg.language, "content_version": msg.content_version}
        got["content"] = msg.content
        assert got == expected
        if "canonical" in case:
            assert encode_message(msg) == (ROOT / case["canonical"]).read_bytes()
        return
    assert _attachments(case, msg) == expected["attachments"]


def test_manifest_names_are_unique_and_files_exist() -> None:
    names = [c["name"] for c in CASES]
    assert len(names) == len(set(names)) and len(names) >= 6
    assert all((ROOT / c["file"]).is_file() for c in CASES)
