"""Python, C++ and Java modules exchange messages through one reference server.

The reference server runs in this process (port 0). `PyMod` is an `openair.client.Module`; the
C++ module (`bindings/cpp/build/openair-shim`) and the Java module
(`bindings/java/target/openair-shim.jar`) are driven as subprocesses through the shim protocol
(`openair-shim/1`). Each registers triggers for the other two languages' posts; each posts once
(UTF-8 text, XML content, multi-line text); Java also posts a type nobody's trigger matches,
cc'ing the C++ module. A Python conductor then posts `Interop.End`, which every module's trigger
matches: it is the last wakeup each module gets, so "exactly once" is judged without waiting.
Every wakeup must arrive once with its message intact, and the three retrieves must agree.

The binaries come from `make cpp` and `make java`. When they are missing the test skips, unless
OPENAIR_REQUIRE_BINDINGS=1 (set by `make test`), which makes it fail.
"""

from __future__ import annotations

import asyncio
import shutil
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from bindings_support import require

from openair.client import Module
from openair.client.shim import message_object, wakeup_object
from openair.protocol.content import RetrieveSpec, Trigger
from openair.server.aio.app import ServerOptions, start_server
from openair_conformance.shim.driver import ShimDriver

ROOT = Path(__file__).resolve().parents[2]
CPP_SHIM = ROOT / "bindings" / "cpp" / "build" / "openair-shim"
JAVA_SHIM = ROOT / "bindings" / "java" / "target" / "openair-shim.jar"

TIMEOUT = 60.0  # an overall bound for the exchange: a hang fails instead of blocking
STEP = 15.0  # one shim command, one wakeup

TEXT = "grüße, 世界 ☃ 🚀 — a < b & c > d"
XML = '<note lang="ja" n="1"><b>日本語</b> &amp; text</note>'
LINES = "first line\n\tsecond: ünïcödé\nthird 🎉 ]]> end"
CC_TEXT = "copied to C++ only: Ωμέγα"
END = "Interop.End"

Json = dict[str, Any]


def _require(*paths: Path) -> None:
    require("bindings", "make cpp java", *paths, java=True)


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
async def shim_module(argv: Sequence[str], port: int, name: str) -> AsyncIterator[ShimDriver]:
    """A shim subprocess connected as module `name` (listening port and callback connection)."""
    driver = ShimDriver(argv)
    await driver.start(STEP)
    try:
        fields = {"host": "127.0.0.1", "port": port, "name": name, "listen": True}
        answer = await driver.command("connect", {**fields, "callback": True}, STEP)
        assert answer["ok"] and answer["legacy"] is False, answer
        yield driver
    finally:
        await driver.close(STEP)


async def shim_ok(driver: ShimDriver, cmd: str, **fields: Any) -> Json:
    """Send one command and return its answer, which must be a success."""
    answer = await driver.command(cmd, fields, STEP)
    assert answer["ok"] is True, (driver.argv, answer, driver.stderr_text)
    return answer


async def shim_register(driver: ShimDriver, *patterns: str) -> None:
    triggers = [{"type": p, "from": "WB1", "after": 0} for p in patterns]
    await shim_ok(driver, "register", triggers=triggers, retrieves=[])


async def shim_post(driver: ShimDriver, type_: str, content: str, **fields: Any) -> str:
    """Post to WB1 through a shim and return the posted message's id."""
    fields = {"xml": False, "cc": [], "priority": None, **fields}
    answer = await shim_ok(driver, "post", to="WB1", type=type_, content=content, **fields)
    id_: str = answer["id"]
    return id_


async def shim_wakeups(driver: ShimDriver) -> list[Json]:
    """The wakeups a shim reports up to and including the one `Interop.End` triggered."""
    woken: list[Json] = []
    while not woken or woken[-1]["trigger"]["type"] != END:
        wakeup: Json = (await shim_ok(driver, "await-wakeup", timeout_ms=int(STEP * 1000)))[
            "wakeup"
        ]
        if wakeup["trigger"] is not None:  # phase updates are not wakeups by a message
            woken.append(wakeup)
    return woken


async def python_wakeups(module: Module) -> list[Json]:
    """The same for the Python module, as shim wakeup objects."""
    woken: list[Json] = []
    while not woken or woken[-1]["trigger"]["type"] != END:
        event = await module.next_wakeup(timeout=STEP)
        assert event is not None, "no wakeup for the Python module"
        if event.wakeup.trigger is not None:
            woken.append(wakeup_object(event))
    return woken


def _as_sent(m: Json) -> tuple[Any, ...]:
    """What the poster wrote, from a message object as the server stored it."""
    return (m["type"], m["id"], m["from"], m["to"], m["cc"], m["content"], m["xml"])


def _arrivals(woken: list[Json], recipient: str) -> list[tuple[str, str]]:
    """(trigger type, lasttrigger) of each wakeup; every wakeup is addressed to `recipient`."""
    assert [w["message"]["to"] for w in woken] == [recipient] * len(woken)
    assert all(w["trigger"]["posted"] is not None for w in woken)  # stamped by each poster
    return [(w["trigger"]["type"], w["lasttrigger"]) for w in woken]


@dataclass(frozen=True, slots=True, kw_only=True)
class Exchange:
    """What happened: each post as written (oldest first), each module's wakeups, retrieves."""

    sent: tuple[tuple[Any, ...], ...]
    woken: dict[str, list[Json]]  # module name -> its wakeups, in arrival order
    retrieved: dict[str, list[Json]]  # language -> what it retrieved from WB1, as returned


@dataclass(frozen=True, slots=True, kw_only=True)
class Peers:
    """The three modules under test and the Python conductor that posts the last message."""

    py: Module
    cpp: ShimDriver
    java: ShimDriver
    conductor: Module


async def register(peers: Peers) -> None:
    """Each module's triggers match the other two languages' posts and the last message."""
    patterns = ("Interop.Cpp.*", "Interop.Java.*", END)
    await peers.py.subscribe([Trigger(pattern=p, whiteboard="WB1") for p in patterns])
    await shim_register(peers.cpp, "Interop.Py.*", "Interop.Java.*", END)
    await shim_register(peers.java, "Interop.Py.*", "Interop.Cpp.*", END)


async def post_all(peers: Peers) -> tuple[tuple[Any, ...], ...]:
    """Post once from each language, a cc-only post, then END; return them as written."""
    py = await peers.py.post("WB1", "Interop.Py.Note", TEXT)
    cpp = await shim_post(peers.cpp, "Interop.Cpp.Xml", XML, xml=True)
    java = await shim_post(peers.java, "Interop.Java.Note", LINES)
    cc = await shim_post(peers.java, "Interop.Cc.Java", CC_TEXT, cc=["CppMod"])
    end = await peers.conductor.post("WB1", END, "the last one")
    return (
        ("Interop.Py.Note", py.id, "PyMod", "WB1", "", TEXT, False),
        ("Interop.Cpp.Xml", cpp, "CppMod", "WB1", "", XML, True),
        ("Interop.Java.Note", java, "JavaMod", "WB1", "", LINES, False),
        ("Interop.Cc.Java", cc, "JavaMod", "WB1", "CppMod", CC_TEXT, False),
        (END, end.id, "Conductor", "WB1", "", "the last one", False),
    )


async def retrieve_all(peers: Peers) -> dict[str, list[Json]]:
    """Every language reads WB1 (`Interop.*`, the latest 10)."""
    spec = {"whiteboard": "WB1", "type": "Interop.*", "latest": 10}
    mine = RetrieveSpec(whiteboard="WB1", pattern="Interop.*", latest=10)
    return {
        "python": [message_object(m) for m in await peers.py.retrieve(mine)],
        "cpp": (await shim_ok(peers.cpp, "retrieve", specs=[spec]))["messages"],
        "java": (await shim_ok(peers.java, "retrieve", specs=[spec]))["messages"],
    }


async def exchange() -> Exchange:
    """Run the exchange on a fresh reference server."""
    java = shutil.which("java") or "java"
    async with (
        reference_server() as port,
        python_module("PyMod", port) as py,
        python_module("Conductor", port) as conductor,
        shim_module([str(CPP_SHIM)], port, "CppMod") as cpp,
        shim_module([java, "-jar", str(JAVA_SHIM)], port, "JavaMod") as jv,
    ):
        peers = Peers(py=py, cpp=cpp, java=jv, conductor=conductor)
        await register(peers)
        sent = await post_all(peers)
        woken = await asyncio.gather(python_wakeups(py), shim_wakeups(cpp), shim_wakeups(jv))
        retrieved = await retrieve_all(peers)
    names = ("PyMod", "CppMod", "JavaMod")
    return Exchange(sent=sent, woken=dict(zip(names, woken, strict=True)), retrieved=retrieved)


@pytest.fixture(scope="module")
def outcome() -> Exchange:
    _require(CPP_SHIM, JAVA_SHIM)

    async def bounded() -> Exchange:
        return await asyncio.wait_for(exchange(), TIMEOUT)

    return asyncio.run(bounded())


def test_every_wakeup_arrives_once_through_the_right_trigger(outcome: Exchange) -> None:
    """In posting order; the cc-only post wakes the C++ module with an empty lasttrigger."""
    assert _arrivals(outcome.woken["PyMod"], "PyMod") == [
        ("Interop.Cpp.Xml", "Interop.Cpp.*"),
        ("Interop.Java.Note", "Interop.Java.*"),
        (END, END),
    ]
    assert _arrivals(outcome.woken["CppMod"], "CppMod") == [
        ("Interop.Py.Note", "Interop.Py.*"),
        ("Interop.Java.Note", "Interop.Java.*"),
        ("Interop.Cc.Java", ""),
        (END, END),
    ]
    assert _arrivals(outcome.woken["JavaMod"], "JavaMod") == [
        ("Interop.Py.Note", "Interop.Py.*"),
        ("Interop.Cpp.Xml", "Interop.Cpp.*"),
        (END, END),
    ]


def test_every_message_arrives_as_its_poster_wrote_it(outcome: Exchange) -> None:
    """Type, id, from, to, cc, UTF-8 or XML content: whoever posted and whoever reads it."""
    written = {m[0]: m for m in outcome.sent}
    triggers = [w["trigger"] for woken in outcome.woken.values() for w in woken]
    assert [t for t in triggers if _as_sent(t) != written[t["type"]]] == []


def test_the_three_retrieves_agree(outcome: Exchange) -> None:
    """Newest first, identical in every language, and identical to every wakeup's copy."""
    python = outcome.retrieved["python"]
    assert outcome.retrieved["cpp"] == python
    assert outcome.retrieved["java"] == python
    assert [_as_sent(m) for m in python] == list(reversed(outcome.sent))
    stored = {m["id"]: m for m in python}
    triggers = [w["trigger"] for woken in outcome.woken.values() for w in woken]
    assert [t for t in triggers if t != stored[t["id"]]] == []
