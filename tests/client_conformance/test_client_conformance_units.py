"""The pieces of client mode: the shim schema and driver, scenario files, values, the command."""

from __future__ import annotations

import asyncio
import importlib
import json
import socket
from pathlib import Path
from typing import Any, cast

import pytest
from click.testing import CliRunner
from client_conformance_support import fake_shim, result, run
from lxml import etree

from openair.catalogue import load_catalogue
from openair.client.shim import Shim, error_code, message_object
from openair.protocol.errors import RequestTimeoutError, XmlMalformedError
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.resources import spec_path
from openair_conformance.client_cli import conform_client
from openair_conformance.clientmode.scenario import (
    SCHEMA_PATH,
    Expect,
    ScenarioError,
    load_scenarios,
    parse_scenario,
)
from openair_conformance.clientmode.values import MISSING, Values, evaluate, lookup
from openair_conformance.model import Verdict
from openair_conformance.shim.driver import (
    ShimDriver,
    ShimProtocolError,
    ShimStartError,
    shim_schema,
    validate_line,
)

_PARSER = etree.XMLParser(resolve_entities=False, no_network=True)
jsonschema: Any = importlib.import_module("jsonschema")  # a test extra without stubs
_READY = {"event": "ready", "protocol": "openair-shim/1", "library": "x", "version": "1"}
_TIMEOUT = {"code": "REQUEST_TIMEOUT", "message": ""}
_MESSAGE = {
    "type": "T.A", "id": "1", "from": "M", "to": "WB1", "cc": "", "stored": "WB1",
    "isresponse": "", "posted": [1, 2], "received": None, "priority": None, "wbid": 3,
    "content": "x", "xml": False,
}  # fmt: skip

# -- the shim schema ----------------------------------------------------------------------------


def test_the_shim_schema_is_a_valid_2020_12_schema() -> None:
    jsonschema.Draft202012Validator.check_schema(shim_schema())


def test_the_error_codes_are_the_error_table() -> None:
    table = etree.parse(str(spec_path("errors.xml")), _PARSER).getroot()
    names = [el.get("name") for el in table.iter("error")]
    assert shim_schema()["$defs"]["errorCode"]["enum"] == names


@pytest.mark.parametrize(
    ("line", "command", "valid"),
    [
        (_READY, None, True),
        ({**_READY, "protocol": "openair-shim/2"}, None, False),
        ({"seq": 1, "ok": True, "bound_port": 10114, "legacy": False}, "connect", True),
        ({"seq": 1, "ok": True, "bound_port": 0, "legacy": False}, "connect", False),
        ({"seq": 1, "ok": True, "bound_port": -1}, "connect", False),
        ({"seq": 1, "ok": True}, "register", True),
        ({"seq": 1, "ok": True, "id": ""}, "post", False),
        ({"seq": 1, "ok": True, "messages": [_MESSAGE]}, "retrieve", True),
        ({"seq": 1, "ok": True, "messages": [{**_MESSAGE, "posted": [1, 1e3]}]}, "retrieve", False),
        ({"seq": 1, "ok": True, "messages": [{**_MESSAGE, "extra": 1}]}, "retrieve", False),
        ({"seq": 1, "ok": False, "error": _TIMEOUT}, "await-wakeup", True),
        ({"seq": 1, "ok": False, "error": {**_TIMEOUT, "code": "TIMEOUT"}}, "await-wakeup", False),
        ({"seq": 1, "ok": True, "wakeup": {"message": _MESSAGE, "trigger": None, "retrieved": [],
          "lasttrigger": "", "received_ns": 5, "path": "callback"}}, "await-wakeup", True),
        ({"seq": 1, "ok": True, "wakeup": {"message": _MESSAGE, "trigger": None, "retrieved": [],
          "lasttrigger": "", "received_ns": 5, "path": "mail"}}, "await-wakeup", False),
        ({"seq": 1, "ok": True, "typo": 1}, None, False),
    ],
)  # fmt: skip
def test_shim_lines_are_checked(line: dict[str, Any], command: str | None, valid: bool) -> None:
    assert (validate_line(line, command) == []) is valid


# -- the Python shim ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("error", "code"),
    [
        (RequestTimeoutError("late"), "REQUEST_TIMEOUT"),
        (XmlMalformedError("bad"), "XML_MALFORMED"),
        (TimeoutError(), "REQUEST_TIMEOUT"),
        (ConnectionRefusedError(), "CONNECTION_CLOSED"),
        (KeyError("host"), "API_MISUSE"),
    ],
)
def test_the_python_shim_names_errors_by_the_table(error: Exception, code: str) -> None:
    assert error_code(error) == code


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def test_the_python_shim_answers_failures_in_protocol_form() -> None:
    async def go() -> list[dict[str, Any]]:
        shim = Shim()
        port = _free_port()  # closed again: nothing listens there
        connect = {"seq": 1, "cmd": "connect", "host": "127.0.0.1", "port": port, "name": "M"}
        return [
            await shim.handle(connect),
            await shim.handle({"seq": 2, "cmd": "post", "to": "WB1", "type": "T"}),
            await shim.handle({"seq": 3, "cmd": "dance"}),
        ]

    answers = asyncio.run(go())
    assert [a["error"]["code"] for a in answers] == [
        "CONNECTION_CLOSED", "API_MISUSE", "API_MISUSE",
    ]  # fmt: skip
    assert [validate_line(a, "connect") for a in answers] == [[], [], []]


def test_the_python_shim_writes_protocol_message_objects() -> None:
    msg = Message(type="T.A", sender="M", to="WB1", priority=3.0, posted=AirTime(sec=5, msec=7))
    obj = message_object(msg)
    assert validate_line({"seq": 1, "ok": True, "messages": [obj]}, "retrieve") == []
    assert (obj["posted"], obj["received"], obj["priority"]) == ([5, 7], None, 3.0)


# -- the driver ---------------------------------------------------------------------------------


def _drive(mode: str, *commands: str) -> tuple[ShimDriver, list[dict[str, Any]]]:
    async def go() -> tuple[ShimDriver, list[dict[str, Any]]]:
        driver = ShimDriver(fake_shim(mode))
        answers = []
        try:
            await driver.start(10.0)
            for cmd in commands:
                answers.append(await driver.command(cmd, {}, 10.0))
        finally:
            await driver.close(5.0)
        return driver, answers

    return asyncio.run(go())


def test_a_good_shim_is_started_commanded_and_closed() -> None:
    lines: list[tuple[str, str]] = []

    async def go() -> int | None:
        driver = ShimDriver(fake_shim("good"), on_line=lambda d, t: lines.append((d, t)))
        info = await driver.start(10.0)
        assert (info.library, info.version, info.label) == ("fake", "1.0", "fake 1.0")
        failed = await driver.command("register", {"triggers": []}, 10.0)
        assert failed["error"]["code"] == "API_MISUSE"
        assert (await driver.command("close", {}, 10.0))["ok"] is True
        return await driver.close(5.0)

    assert asyncio.run(go()) == 0
    assert [d for d, _ in lines] == ["in", "out", "in", "out", "in"]
    assert json.loads(lines[1][1]) == {"seq": 1, "cmd": "register", "triggers": []}


@pytest.mark.parametrize(
    ("mode", "words"),
    [
        ("garbage", "not JSON"),
        ("wrong-seq", "seq 2, not 1"),
        ("bad-answer", "legacy"),
        ("exit", "closed its output (exit code 1)"),
    ],
)
def test_a_shim_that_breaks_the_protocol_is_caught(mode: str, words: str) -> None:
    with pytest.raises(ShimProtocolError, match=words.replace("(", r"\(").replace(")", r"\)")):
        _drive(mode, "connect")


@pytest.mark.parametrize("mode", ["bad-ready", "silent"])
def test_a_shim_that_never_says_ready_does_not_start(mode: str) -> None:
    async def go() -> None:
        driver = ShimDriver(fake_shim(mode))
        try:
            await driver.start(0.5)
        finally:
            await driver.kill()

    with pytest.raises(ShimStartError):
        asyncio.run(go())


def test_a_missing_program_does_not_start() -> None:
    with pytest.raises(ShimStartError, match="cannot start"):
        asyncio.run(ShimDriver(["/nonexistent/shim"]).start(1.0))


def test_an_invalid_answer_fails_the_scenario() -> None:
    judged = result(run(fake_shim("bad-answer"), ["CLI-001"]), "CLI-001")
    assert judged.verdict is Verdict.FAIL
    assert "invalid answer to connect" in judged.message
    assert any(e.conn == "shim" and e.direction == "in" for e in judged.trace)


# -- scenario files -----------------------------------------------------------------------------


def test_every_shipped_scenario_is_valid_and_cites_known_requirements() -> None:
    scenarios = load_scenarios()
    catalogue = load_catalogue()
    ids = [s.info.id for s in scenarios]
    assert len(ids) == len(set(ids)) >= 15
    unknown = {r for s in scenarios for r in s.info.requirements if r not in catalogue}
    assert unknown == set()


def test_every_peer_kind_is_used_by_a_scenario() -> None:
    xsd = etree.parse(str(SCHEMA_PATH), _PARSER).getroot()
    ns = {"xs": "http://www.w3.org/2001/XMLSchema"}
    path = "//xs:simpleType[@name='PeerKindType']//xs:enumeration/@value"
    kinds = cast(list[str], xsd.xpath(path, namespaces=ns))
    used = {s.peer.kind for s in load_scenarios()}
    assert set(kinds) == used


_MINIMAL = """<scenario id="CLI-900" level="MUST" section="6.3">
  <title>A scenario</title>
  <requirement id="OA-SESS-3"/>
  <peer kind="reference"/>
  <steps>{steps}</steps>
</scenario>"""


def test_a_minimal_scenario_loads() -> None:
    steps = '<connect listen="false"><expect path="bound_port" equals="-1"/></connect>'
    scenario = parse_scenario(_MINIMAL.format(steps=steps).encode())
    (step,) = scenario.steps
    assert (step.kind, step.flag("listen", True), step.flag("callback", True)) == (
        "connect", False, True,
    )  # fmt: skip
    assert step.expects == (Expect(path="bound_port", test="equals", value="-1", line=5),)


@pytest.mark.parametrize(
    ("document", "words"),
    [
        (_MINIMAL.format(steps="<connect/>").replace("<title>A scenario</title>", ""), "line 3"),
        (_MINIMAL.format(steps="<dance/>"), "dance"),
        (_MINIMAL.format(steps='<connect><expect path="a" equals="1" count="2"/></connect>'),
         "exactly one"),
        (_MINIMAL.format(steps='<connect requirement="OA-SESS-5"/>'), "not among"),
        ('<!DOCTYPE scenario [<!ENTITY x "y">]>' + _MINIMAL.format(steps="<connect/>"),
         "DOCTYPE"),
        (_MINIMAL.format(steps="<connect/>").replace("CLI-900", "CASE-1"), "CASE-1"),
    ],
)  # fmt: skip
def test_a_bad_scenario_is_refused_with_the_reason(document: str, words: str) -> None:
    with pytest.raises(ScenarioError, match=words):
        parse_scenario(document.encode(), "bad.xml")


def test_a_duplicate_id_is_refused(tmp_path: Path) -> None:
    for name in ("a.xml", "b.xml"):
        (tmp_path / name).write_text(_MINIMAL.format(steps="<connect/>"), encoding="utf-8")
    with pytest.raises(ScenarioError, match="CLI-900"):
        load_scenarios(tmp_path)


# -- values ---------------------------------------------------------------------------------------


def test_lookup_follows_paths() -> None:
    value = {"messages": [{"id": "a", "n": 2}], "flag": False}
    assert lookup(value, "messages[0].id") == "a"
    assert lookup(value, "flag") is False
    assert lookup(value, "messages[1].id") is MISSING
    assert lookup(value, "messages.id") is MISSING


def test_placeholders_expand_and_unknown_ones_are_errors() -> None:
    values = Values(T="Conf.X", module="M")
    values.save("go", {"id": "42", "n": 3.0})
    assert values.expand("{T}.Go/{module}/{go.id}/{go.n}") == "Conf.X.Go/M/42/3.0"
    with pytest.raises(KeyError):
        values.expand("{nothing}")
    with pytest.raises(KeyError):
        values.expand("{go.missing}")


@pytest.mark.parametrize(
    ("test", "actual", "expected", "holds"),
    [
        ("equals", 3.0, "3", True),
        ("equals", 3, "3.0", True),
        ("equals", True, "true", True),
        ("equals", None, "null", True),
        ("equals", "", "", True),
        ("equals", MISSING, "", False),
        ("equals", "1", "1.0", False),
        ("not-equals", "a", "b", True),
        ("not-equals", MISSING, "b", False),
        ("count", [1, 2], "2", True),
        ("count", "ab", "2", False),
        ("min", 5, "1", True),
        ("min", True, "1", False),
        ("present", None, "true", False),
        ("present", None, "false", True),
        ("one-of", "b", "a b c", True),
        ("one-of", "d", "a b c", False),
    ],
)
def test_expect_tests(test: str, actual: Any, expected: str, holds: bool) -> None:
    assert evaluate(Expect(path="p", test=test, value=expected), actual, expected) is holds


# -- the command ----------------------------------------------------------------------------------


def test_list_shows_every_scenario() -> None:
    outcome = CliRunner().invoke(conform_client, ["--list"])
    assert outcome.exit_code == 0, outcome.output
    lines = outcome.output.splitlines()
    assert [line.split()[0] for line in lines] == [s.info.id for s in load_scenarios()]


@pytest.mark.parametrize(
    "args",
    [
        [],
        ["--shim", ""],
        ["--shim", "'unclosed"],
        ["--shim", "python", "--scenario", "NOPE-*"],
        ["--shim", "python", "--jobs", "0"],
    ],
)
def test_usage_errors_exit_2(args: list[str]) -> None:
    assert CliRunner().invoke(conform_client, args).exit_code == 2


def test_a_bad_scenario_folder_is_a_usage_error(tmp_path: Path) -> None:
    (tmp_path / "x.xml").write_text("<scenario/>", encoding="utf-8")
    outcome = CliRunner().invoke(conform_client, ["--list", "--scenario-dir", str(tmp_path)])
    assert outcome.exit_code == 2


def test_a_shim_that_cannot_start_exits_3() -> None:
    outcome = CliRunner().invoke(conform_client, ["--shim", "/nonexistent/shim"])
    assert outcome.exit_code == 3
    assert "cannot start" in outcome.output


def test_a_failing_scenario_exits_1_and_writes_the_report(tmp_path: Path) -> None:
    report = tmp_path / "fake.json"
    shim = " ".join(fake_shim("good"))
    args = ["--shim", shim, "--scenario", "CLI-001", "--json", str(report)]
    outcome = CliRunner().invoke(conform_client, args)
    assert outcome.exit_code == 1, outcome.output
    data = json.loads(report.read_text(encoding="utf-8"))
    assert [(r["id"], r["verdict"]) for r in data["results"]] == [("CLI-001", "fail")]
    ok = CliRunner().invoke(conform_client, [*args, "--fail-on", "none"])
    assert ok.exit_code == 0
