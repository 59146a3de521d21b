"""The world model over a real server, in process: two robots, SYSTEM objects, staleness, and
the conformance checker run against the reference implementation (OA-WM-14, spec 16.6)."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

from click.testing import CliRunner

from openair.cli import main
from openair.server.aio.app import ServerOptions, start_server
from openair_conformance.worldmodel import CASES, run_cases
from openair_worldmodel import Context
from openair_worldmodel.node import WorldModelNode

BOUND = 20.0


def _run(body: Callable[[int], Awaitable[None]]) -> None:
    async def main_() -> None:
        server = await start_server(ServerOptions(port=0, monitor=False))
        try:
            async with asyncio.timeout(60):
                await body(server.port)
        finally:
            await server.stop()

    asyncio.run(main_())


def test_two_robots_share_system_objects_and_a_lost_robot_goes_stale() -> None:
    async def body(port: int) -> None:
        a = WorldModelNode("A1", robot="RA", whiteboard="WB1", port=port, peers=["WB2"])
        b = WorldModelNode("B1", robot="RB", whiteboard="WB2", port=port, peers=["WB1"])
        await a.start()
        await b.start()
        try:
            a.create("RA.Intent", context=Context.SYSTEM)
            a.create("RA.Secret", context=Context.SELF)
            b.create("RB.Intent", context=Context.SYSTEM)
            await a.write("RA.Intent", "goal", "dock")
            await a.write("RA.Secret", "battery", 0.2)
            await b.write("RB.Intent", "goal", "explore")
            assert await b.wait_for(lambda: b.core.lookup("RA.Intent", "goal") is not None, BOUND)
            assert await a.wait_for(lambda: a.core.lookup("RB.Intent", "goal") is not None, BOUND)
            assert "RA.Secret" not in b.core.blackboard.objects  # only SYSTEM crosses robots
            assert b.core.blackboard.objects["RA.Intent"].owner == "RA"
            await a.close()  # robot RA disappears: the server posts Psyclone.Module.Lost.A1
            assert await b.wait_for(lambda: b.core.blackboard.objects["RA.Intent"].stale, BOUND)
            assert b.core.lookup("RA.Intent", "goal") is None  # conditions no longer see it
            assert not b.core.blackboard.objects["RB.Intent"].stale
        finally:
            await a.close()
            await b.close()

    _run(body)


def test_a_late_module_catches_up_and_replicas_agree() -> None:
    async def body(port: int) -> None:
        async with WorldModelNode("Early", robot="R", whiteboard="WB1", port=port) as early:
            early.create("Thing")
            for i in range(5):
                await early.write("Thing", "n", float(i))
            async with WorldModelNode("Late", robot="R", whiteboard="WB1", port=port) as late:
                await early.write("Thing", "m", "after")
                assert await late.wait_for(
                    lambda: late.core.blackboard.stored("Thing", "m") is not None, BOUND
                )
                assert late.core.blackboard.snapshot() == early.core.blackboard.snapshot()

    _run(body)


def test_the_conformance_checker_passes_the_reference_implementation() -> None:
    async def body(port: int) -> None:
        async with WorldModelNode("WMImpl", robot="R", whiteboard="WB1", port=port):
            results = await run_cases("127.0.0.1", port, "WMImpl", bound=BOUND)
        assert [(r.case.id, r.verdict, r.detail) for r in results] == [
            (c.id, "passed", "") for c in CASES
        ]

    _run(body)


def test_the_checker_fails_a_module_that_is_not_there() -> None:
    async def body(port: int) -> None:
        results = await run_cases("127.0.0.1", port, "Nobody", bound=0.5, select="WM-00")
        assert results and all(r.verdict == "failed" for r in results)

    _run(body)


def test_cli_command_is_registered() -> None:
    result = CliRunner().invoke(main, ["conform-worldmodel", "--help"])
    assert result.exit_code == 0 and "WM-001" in result.output
    bad = CliRunner().invoke(main, ["conform-worldmodel", "nohost", "--module", "M"])
    assert bad.exit_code == 2
