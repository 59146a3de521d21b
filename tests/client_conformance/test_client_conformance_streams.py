"""Client mode for streams: the `call` step's placeholders, the not-applicable rule for a shim
without streams, and a binding without streams reported not-applicable, never as a pass."""

from __future__ import annotations

import sys

import pytest
from client_conformance_support import HERE, result, run

from openair_conformance.clientmode.streamsteps import expand_json, not_applicable
from openair_conformance.clientmode.values import Values
from openair_conformance.model import Verdict
from openair_conformance.shim.driver import STREAM_COMMANDS, validate_line

STREAMLESS_SHIM = (sys.executable, str(HERE / "streamless_client_shim.py"))


def _values() -> Values:
    values = Values(T="Conf.X", module="Lib", kit="Kit")
    values.save("a", {"sample_id": 7, "name": "Cam", "ids": [4, 5]})
    return values


def test_a_whole_placeholder_keeps_the_saved_type() -> None:
    got = expand_json({"id": "{a.sample_id}", "first": "{a.ids[1]}", "n": 3}, _values())
    assert got == {"id": 7, "first": 5, "n": 3}


def test_placeholders_inside_text_are_expanded_as_text() -> None:
    got = expand_json({"stream": "{T}.Cam", "list": ["x{a.sample_id}", "{a.name}"]}, _values())
    assert got == {"stream": "Conf.X.Cam", "list": ["x7", "Cam"]}


def test_an_unsaved_placeholder_is_a_scenario_bug() -> None:
    with pytest.raises(KeyError):
        expand_json({"id": "{nothing.here}"}, _values())


def _failure(code: str, message: str) -> dict[str, object]:
    return {"seq": 1, "ok": False, "error": {"code": code, "message": message}}


@pytest.mark.parametrize("cmd", sorted(STREAM_COMMANDS))
def test_unknown_stream_command_is_not_applicable(cmd: str) -> None:
    verdict = not_applicable(cmd, _failure("API_MISUSE", f"unknown command {cmd!r}"))
    assert verdict is not None and "does not offer streams" in str(verdict)


@pytest.mark.parametrize(
    ("cmd", "answer"),
    [
        ("stream-add", _failure("API_MISUSE", "stream must name a stream")),  # misuse, not absence
        ("stream-add", _failure("SAMPLE_INVALID", "unknown command")),  # another code
        ("connect", _failure("API_MISUSE", "unknown command 'connect'")),  # not optional
        ("stream-add", {"seq": 1, "ok": True, "sample_id": 1}),
    ],
)
def test_other_answers_are_judged_normally(cmd: str, answer: dict[str, object]) -> None:
    assert not_applicable(cmd, answer) is None


def test_an_unsupported_attachments_field_is_not_applicable() -> None:
    verdict = not_applicable("post", _failure("API_MISUSE", "unsupported field: attachments"))
    assert verdict is not None and "attachments" in str(verdict)


def _received(payload: str) -> dict[str, object]:
    sample = {"id": 1, "timestamp": 5, "size": 2, "payload": payload, "params": [["k", "v"]]}
    received = {"stream": "S", "sample": sample, "dropped": 0, "received_ns": 1}
    return {"seq": 3, "ok": True, "received": received}


def test_the_schema_accepts_a_received_sample_and_refuses_bad_base64() -> None:
    assert validate_line(_received("AAE="), "stream-next") == []
    assert validate_line(_received("A*=="), "stream-next") != []


def test_a_binding_without_streams_is_not_applicable_never_passing() -> None:
    summary = run(STREAMLESS_SHIM, ["CLI-021", "CLI-025", "CLI-006"], jobs=3)
    for scenario_id in ("CLI-021", "CLI-025"):
        got = result(summary, scenario_id)
        assert got.verdict is Verdict.NOT_APPLICABLE, got.message
        assert "the shim does not offer streams" in got.message
    assert result(summary, "CLI-006").verdict is Verdict.PASS  # the rest of it is judged as usual
