"""The navigation sensor: reports the robot's pose (SELF) while the vehicle moves."""

from __future__ import annotations

import asyncio

from wm_common import POSE, ROBOT, STEP, VEHICLE, WHITEBOARD, arguments

from openair_worldmodel import ClassDef, Context, Packet
from openair_worldmodel.node import WorldModelNode

POSE_CLASS = ClassDef(
    name="Pose",
    attributes=(("x", None), ("y", Packet(value=0.0)), ("heading", Packet(value=0.0))),
)


async def run(host: str, port: int, *, tick: float = 0.05, max_steps: int = 400) -> float:
    """Move along x by STEP per tick while the vehicle is `moving`; return the final x."""
    async with WorldModelNode(
        "Nav", robot=ROBOT, whiteboard=WHITEBOARD, host=host, port=port
    ) as node:
        await node.define(POSE_CLASS)
        node.create(POSE, "Pose", Context.SELF)
        x = 0.0
        for attribute, value in (("x", x), ("y", 0.0), ("heading", 0.0)):
            node.note(POSE, attribute, value, accuracy=0.02)
        await node.flush()
        print("ready", flush=True)
        steps = 0
        while steps < max_steps:
            state = node.core.lookup(VEHICLE, "state")
            if state is not None and state.value == "stopped":
                break
            if state is not None and state.value == "moving":
                x += STEP
                steps += 1
                await node.write(POSE, "x", x, accuracy=0.02)
            await asyncio.sleep(tick)  # the sensor's rate, not a synchronisation
        print(f"Nav: vehicle stopped at x={x:.2f}", flush=True)
        return x


if __name__ == "__main__":
    args = arguments(__doc__ or "")
    asyncio.run(run(args.host, args.port))
