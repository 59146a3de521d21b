"""The world model across robots on different cluster nodes (spec 16 over spec 17, issue #22).

Robot RA's modules are bound to node n1, robot RB's to n2: RA's SYSTEM objects reach RB through
the shared whiteboards, its SELF objects do not, and when RA's module leaves (its node posts
Psyclone.Module.Lost to the shared AIRCentral) RB marks RA's objects stale (OA-WM-14).
"""

from __future__ import annotations

import asyncio
import contextlib

import pytest
from netcluster import Cluster, run_in

from openair_worldmodel import Context
from openair_worldmodel.node import WorldModelNode

pytestmark = pytest.mark.slow
BOUND = 20.0


def test_system_facts_cross_nodes_and_a_lost_robot_goes_stale(cluster: Cluster) -> None:
    n1, n2 = cluster.nodes[0], cluster.nodes[1]

    async def body() -> None:
        a = WorldModelNode(
            "WmA1", robot="RA", whiteboard="WB1", host=n1.address, port=10000, peers=["WB2"]
        )
        b = WorldModelNode(
            "WmB1", robot="RB", whiteboard="WB2", host=n2.address, port=10000, peers=["WB1"]
        )
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
            await a.close()  # n1 posts Psyclone.Module.Lost.WmA1 to the shared AIRCentral
            assert await b.wait_for(lambda: b.core.blackboard.objects["RA.Intent"].stale, BOUND)
            assert b.core.lookup("RA.Intent", "goal") is None
            assert not b.core.blackboard.objects["RB.Intent"].stale
        finally:
            await a.close()
            await b.close()

    run_in(cluster.client_ns, asyncio.wait_for(body(), 60), timeout=90)


@pytest.mark.timeout(240)
def test_a_dead_nodes_robot_goes_stale_on_the_other_nodes(cluster: Cluster) -> None:
    n1, n3 = cluster.nodes[0], cluster.nodes[2]

    async def body() -> tuple[bool, bool]:
        a = WorldModelNode(
            "WmA3", robot="RA3", whiteboard="WB1", host=n3.address, port=10000, peers=["WB2"]
        )
        b = WorldModelNode(
            "WmB3", robot="RB3", whiteboard="WB2", host=n1.address, port=10000, peers=["WB1"]
        )
        await a.start()
        await b.start()
        try:
            a.create("RA3.Intent", context=Context.SYSTEM)
            await a.write("RA3.Intent", "goal", "dock")
            assert await b.wait_for(lambda: b.core.lookup("RA3.Intent", "goal") is not None, BOUND)
            await asyncio.get_running_loop().run_in_executor(None, lambda: cluster.kill(n3))
            # No node posts Lost for WmA3 but a survivor that stops hearing n3 (OA-CLU-7).
            stale = await b.wait_for(lambda: b.core.blackboard.objects["RA3.Intent"].stale, BOUND)
            return stale, b.core.lookup("RA3.Intent", "goal") is None
        finally:
            await b.close()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(a.close(), 5)

    try:
        stale, unseen = run_in(cluster.client_ns, body(), timeout=120)
    finally:
        cluster.restart(n3)
    assert stale and unseen
