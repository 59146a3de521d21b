"""The C++ binding against the kit: conformance, deliberately broken shims, interop with Python.

(a) `openair conform-client --shim bindings/cpp/build/openair-shim` passes every scenario.
(b) `openair-shim-broken --break NAME` (a test-only binary: shim-layer breaks, or a library fault
    hook compiled only under OPENAIR_TEST_FAULTS) fails exactly the scenarios listed in `BREAKS`
    among those it runs, and passes a control scenario the break does not touch.
(c) C++ and Python modules exchange messages through the reference server: the C++ example
    reader is woken by Python posts, a Python module by a C++ post (and another by its cc), and
    the C++ client retrieves what both posted; types, ids and UTF-8 content arrive intact.

The binaries come from `make test-cpp` (or `make cpp`). When they are missing the tests skip,
unless OPENAIR_REQUIRE_BINDINGS=1 (set by `make test`), which makes them fail.
"""

from __future__ import annotations

import asyncio
import subprocess
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from bindings_support import (
    ROOT,
    STREAM_BREAKS,
    breaks_without,
    check_break,
    check_every_scenario_passes,
    require,
    run_breaks,
    run_real_shim,
)

from openair.client import Module, WakeupEvent
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.message import Message
from openair.server.aio.app import ServerOptions, start_server
from openair_conformance.model import RunSummary
from openair_conformance.shim.driver import ShimDriver

BUILD = ROOT / "bindings" / "cpp" / "build"
SHIM = BUILD / "openair-shim"
BROKEN_SHIM = BUILD / "openair-shim-broken"
READER = BUILD / "reader"
LIBRARY = BUILD / "libopenair_client.a"
FAULTS_LIBRARY = BUILD / "libopenair_client_faults.a"

TIMEOUT = 60.0  # an overall bound for one interop exchange: a hang fails instead of blocking
# The C++ broken shim offers every break of the shared table, the stream ones included.
BREAKS = {**breaks_without(), **STREAM_BREAKS}


def _require(*paths: Path) -> None:
    require("C++ binding", "make test-cpp", *paths)


# -- (a) the real shim passes every scenario --------------------------------------------------


@pytest.fixture(scope="module")
def real_report(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, str, dict[str, Any]]:
    _require(SHIM)
    return run_real_shim(str(SHIM), tmp_path_factory.mktemp("cpp-shim") / "cpp.json")


def test_the_cpp_shim_passes_every_scenario(real_report: tuple[int, str, dict[str, Any]]) -> None:
    check_every_scenario_passes(real_report, "openair-cpp 0.1.0")


# -- (b) every deliberately broken behaviour is caught ----------------------------------------


@pytest.fixture(scope="module")
def broken_runs() -> dict[str, RunSummary]:
    """Run every break on its catching scenarios and its control, JOBS breaks at a time."""
    _require(BROKEN_SHIM)
    return run_breaks(BREAKS, lambda name: (str(BROKEN_SHIM), "--break", name))


def test_the_broken_shim_offers_exactly_the_listed_breaks() -> None:
    _require(BROKEN_SHIM)
    listed = subprocess.run(
        [str(BROKEN_SHIM), "--list"], capture_output=True, text=True, check=True, timeout=30
    )
    assert sorted(listed.stdout.split()) == sorted(BREAKS)
    assert len(BREAKS) >= 8
    unknown = subprocess.run(
        [str(BROKEN_SHIM), "--break", "no-such-break"], capture_output=True, text=True, timeout=30
    )
    assert unknown.returncode == 2 and "usage" in unknown.stderr


@pytest.mark.parametrize("name", sorted(BREAKS))
def test_a_broken_behaviour_fails_its_scenarios(
    name: str, broken_runs: dict[str, RunSummary]
) -> None:
    check_break(BREAKS[name], broken_runs[name])


def test_the_library_itself_has_no_fault_hooks() -> None:
    _require(LIBRARY, FAULTS_LIBRARY, SHIM)
    marker = b"6faults"  # in every mangled name of openair::detail::faults
    assert marker in FAULTS_LIBRARY.read_bytes()  # so the check below can fail
    assert marker not in LIBRARY.read_bytes()
    assert marker not in SHIM.read_bytes()
    assert b"lowercase-postedtime" not in SHIM.read_bytes()


# -- (c) interop: C++ and Python modules through the reference server -------------------------

TEXT = "grüße, 世界 ☃ 🚀 — a < b & c > d"
LINES = "first line\n\tsecond: ünïcödé\nthird 🎉"
XML = '<note lang="ja" n="1"><b>日本語</b> &amp; text</note>'


def run_bounded(test: Callable[[], Awaitable[None]]) -> None:
    """Run one async exchange with an overall deadline."""

    async def bounded() -> None:
        await asyncio.wait_for(test(), TIMEOUT)

    asyncio.run(bounded())


@asynccontextmanager
async def reference_server() -> AsyncIterator[int]:
    """The reference server in this process on 127.0.0.1, a free port; yields the port."""
    server = await start_server(ServerOptions(host="127.0.0.1", port=0))
    try:
        yield server.port
    finally:
        await server.stop()


@asynccontextmanager
async def python_module(name: str, port: int) -> AsyncIterator[Module]:
    async with Module(name, port=port, keepalive=None) as module:
        yield module


@asynccontextmanager
async def cpp_shim(port: int, name: str) -> AsyncIterator[ShimDriver]:
    """The C++ shim, connected as module `name` (listening port and callback connection)."""
    driver = ShimDriver([str(SHIM)])
    await driver.start(10.0)
    try:
        fields = {"host": "127.0.0.1", "port": port, "name": name, "listen": True}
        answer = await driver.command("connect", {**fields, "callback": True}, 10.0)
        assert answer["ok"] and answer["legacy"] is False, answer
        yield driver
    finally:
        await driver.close(10.0)


async def shim_ok(driver: ShimDriver, cmd: str, **fields: Any) -> dict[str, Any]:
    """Send one command and return its answer, which must be a success."""
    answer = await driver.command(cmd, fields, 15.0)
    assert answer["ok"] is True, answer
    return answer


async def next_trigger(module: Module) -> WakeupEvent:
    """The next wakeup that carries a trigger message (phase updates skipped)."""
    while True:
        event = await module.next_wakeup(timeout=15.0)
        assert event is not None, "no wakeup"
        if event.wakeup.trigger is not None:
            return event


async def cpp_trigger(driver: ShimDriver) -> dict[str, Any]:
    """The next wakeup the C++ shim reports that carries a trigger (phase updates skipped)."""
    while True:
        wakeup: dict[str, Any] = (await shim_ok(driver, "await-wakeup", timeout_ms=15000))["wakeup"]
        if wakeup["trigger"] is not None:
            return wakeup


def _wakeup_line(msg: Message, sender: str) -> str:
    return f"wakeup {msg.type} from {sender} on WB1 (trigger Interop.Ping.*, via callback): "


def test_python_posts_wake_the_cpp_reader() -> None:
    _require(READER)

    async def exchange() -> None:
        async with reference_server() as port, python_module("PyPoster", port) as poster:
            reader = await asyncio.create_subprocess_exec(
                str(READER), "--port", str(port), "--name", "CppReader", "--type",
                "Interop.Ping.*", "--from", "WB1", "--count", "2", "--timeout-ms", "20000",
                stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
            )  # fmt: skip
            assert reader.stdout is not None
            try:
                ready = (await reader.stdout.readline()).decode("utf-8")
                assert ready.startswith("ready: CppReader bound port "), ready
                await poster.post("WB1", "Interop.Other", "not for the reader")
                first = await poster.post("WB1", "Interop.Ping.A", TEXT)
                second = await poster.post("WB1", "Interop.Ping.Xml", XML, content_is_xml=True)
                out, err = await reader.communicate()
            finally:
                if reader.returncode is None:
                    reader.kill()
                    await reader.wait()
            assert reader.returncode == 0, err.decode("utf-8", "replace")
            assert out.decode("utf-8").splitlines() == [
                _wakeup_line(first, "PyPoster") + TEXT,
                _wakeup_line(second, "PyPoster") + XML,
            ]

    run_bounded(exchange)


def _fields(m: dict[str, Any]) -> tuple[Any, ...]:
    """What must survive a trip between the bindings, from a shim message object."""
    return (m["type"], m["id"], m["from"], m["to"], m["cc"], m["content"], m["xml"])


def _python_fields(m: Message) -> tuple[Any, ...]:
    return (m.type, m.id, m.sender, m.to, m.cc, m.content, m.content_is_xml)


@dataclass(frozen=True, slots=True, kw_only=True)
class Peers:
    """Two Python modules and the C++ module (through its shim), on one reference server."""

    py_reader: Module  # registered for Interop.Cpp.* on WB1
    py_copied: Module  # registered for nothing: woken by cc only
    cpp: ShimDriver  # registered for Interop.Py.* on WB1


async def cpp_posts_wake_python(peers: Peers) -> list[tuple[Any, ...]]:
    """C++ posts text (cc PyCopied) and XML; return what it sent, newest first."""
    note = await shim_ok(
        peers.cpp, "post", to="WB1", type="Interop.Cpp.Note", content=TEXT, xml=False,
        cc=["PyCopied"], priority=2.5,
    )  # fmt: skip
    sent_note = ("Interop.Cpp.Note", note["id"], "CppModule", "WB1", "PyCopied", TEXT, False)
    woken = await next_trigger(peers.py_reader)
    trigger = woken.wakeup.trigger
    assert trigger is not None and woken.wakeup.lasttrigger == "Interop.Cpp.*"
    assert _python_fields(trigger) == sent_note
    assert (trigger.priority, trigger.stored) == (2.5, "WB1")
    assert trigger.posted is not None  # stamped by the C++ client (OA-TIME-2)
    copied = await next_trigger(peers.py_copied)
    assert copied.wakeup.trigger is not None and copied.wakeup.lasttrigger == ""
    assert _python_fields(copied.wakeup.trigger) == sent_note

    xml = await shim_ok(
        peers.cpp, "post", to="WB1", type="Interop.Cpp.Xml", content=XML, xml=True, cc=[],
        priority=None,
    )  # fmt: skip
    sent_xml = ("Interop.Cpp.Xml", xml["id"], "CppModule", "WB1", "", XML, True)
    woken = await next_trigger(peers.py_reader)
    assert woken.wakeup.trigger is not None
    assert _python_fields(woken.wakeup.trigger) == sent_xml
    return [sent_xml, sent_note]


async def python_posts_wake_cpp(peers: Peers) -> tuple[Any, ...]:
    """Python posts to the C++ trigger, then cc's the C++ module; return the first as sent."""
    lines = await peers.py_reader.post("WB1", "Interop.Py.Lines", LINES)
    wakeup = await cpp_trigger(peers.cpp)
    assert _fields(wakeup["trigger"]) == _python_fields(lines)
    assert (wakeup["lasttrigger"], wakeup["message"]["to"]) == ("Interop.Py.*", "CppModule")
    assert wakeup["trigger"]["posted"] is not None
    cc = await peers.py_copied.post("WB2", "Interop.Cc.Only", TEXT, cc=["CppModule"])
    wakeup = await cpp_trigger(peers.cpp)
    assert _fields(wakeup["trigger"]) == _python_fields(cc)
    assert wakeup["lasttrigger"] == ""
    return _python_fields(lines)


def test_cpp_and_python_modules_exchange_messages() -> None:
    _require(SHIM)

    async def exchange() -> None:
        async with (
            reference_server() as port,
            python_module("PyReader", port) as py_reader,
            python_module("PyCopied", port) as py_copied,
            cpp_shim(port, "CppModule") as cpp,
        ):
            await py_reader.subscribe(Trigger(pattern="Interop.Cpp.*", whiteboard="WB1"))
            triggers = [{"type": "Interop.Py.*", "from": "WB1", "after": 0}]
            await shim_ok(cpp, "register", triggers=triggers, retrieves=[])
            peers = Peers(py_reader=py_reader, py_copied=py_copied, cpp=cpp)
            from_cpp = await cpp_posts_wake_python(peers)
            from_python = await python_posts_wake_cpp(peers)

            # C++ retrieves what both bindings posted on WB1, newest first, as it was posted.
            spec = {"whiteboard": "WB1", "type": "Interop.*", "latest": 10}
            found = (await shim_ok(cpp, "retrieve", specs=[spec]))["messages"]
            assert [_fields(m) for m in found] == [from_python, *from_cpp]
            # and Python retrieves what C++ posted.
            mine = RetrieveSpec(whiteboard="WB1", pattern="Interop.Cpp.*", latest=2)
            assert [_python_fields(m) for m in await py_copied.retrieve(mine)] == from_cpp

    run_bounded(exchange)
