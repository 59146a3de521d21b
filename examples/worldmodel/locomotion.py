"""The locomotion module: executes plans; `Loco.Stop` stops the vehicle."""

from __future__ import annotations

import asyncio

from wm_common import MEASURING_OBSTACLE, POSE, ROBOT, VEHICLE, WHITEBOARD, arguments, clearance

from openair_worldmodel import Context, Fire
from openair_worldmodel.node import WorldModelNode


async def run(host: str, port: int, stop: asyncio.Event | None = None) -> None:
    """Hold the vehicle's state; `Demo.Go` starts it, the plan's `Loco.Stop` stops it."""

    def go(node: WorldModelNode, type_: str, content: str) -> None:
        node.note(VEHICLE, "state", "moving")

    def halt(node: WorldModelNode, fire: Fire) -> None:
        pose = node.core.lookup(POSE, "x")
        where = f"x={pose.value}" if pose is not None else "an unknown place"
        print(f"Locomotion: STOP at {where} (plan {fire.plan.name})", flush=True)
        node.note(VEHICLE, "state", "stopped")

    async with WorldModelNode(
        "Locomotion",
        robot=ROBOT,
        whiteboard=WHITEBOARD,
        host=host,
        port=port,
        extra_triggers={"Demo.Go": go},
    ) as node:
        node.core.blackboard.register_function("clearance", clearance)
        await node.define(MEASURING_OBSTACLE)
        node.create(VEHICLE, "Object", Context.SELF)
        node.control("Loco.Stop", halt)
        await node.write(VEHICLE, "state", "idle")
        print("ready", flush=True)
        await (stop or asyncio.Event()).wait()


if __name__ == "__main__":
    args = arguments(__doc__ or "")
    asyncio.run(run(args.host, args.port))
