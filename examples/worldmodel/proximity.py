"""The proximity sensor: reports the obstacle's range and bearing relative to the robot."""

from __future__ import annotations

import asyncio
import math

from wm_common import (
    OBSTACLE,
    OBSTACLE_CLASS,
    POSE,
    ROBOT,
    SENSOR_RANGE,
    TRUE_OBSTACLE,
    VEHICLE,
    WHITEBOARD,
    arguments,
)

from openair_worldmodel import Context
from openair_worldmodel.node import WorldModelNode


async def run(host: str, port: int) -> None:
    """Measure once per new pose (the simulated sensor sees the true obstacle)."""
    async with WorldModelNode(
        "Proximity", robot=ROBOT, whiteboard=WHITEBOARD, host=host, port=port
    ) as node:
        await node.define(OBSTACLE_CLASS)
        node.create(OBSTACLE, "Obstacle", Context.SURROUNDINGS)
        print("ready", flush=True)
        seen = -1

        def pose_changed() -> bool:
            packet = node.core.lookup(POSE, "x")
            state = node.core.lookup(VEHICLE, "state")
            stopped = state is not None and state.value == "stopped"
            return stopped or (packet is not None and packet.timestamp != seen)

        while await node.wait_for(pose_changed, timeout=60.0):
            state = node.core.lookup(VEHICLE, "state")
            if state is not None and state.value == "stopped":
                break
            parts = [node.core.lookup(POSE, a) for a in ("x", "y", "heading")]
            if any(p is None or not isinstance(p.value, float) for p in parts):
                continue
            x, y, heading = (float(p.value) for p in parts if p is not None)  # type: ignore[arg-type]
            seen = parts[0].timestamp if parts[0] is not None else seen
            dx, dy = TRUE_OBSTACLE[0] - x, TRUE_OBSTACLE[1] - y
            rng = math.hypot(dx, dy)
            if rng > SENSOR_RANGE:
                continue
            stamp = max(p.timestamp for p in parts if p is not None)
            node.note(
                OBSTACLE, "range", round(rng, 6), accuracy=0.05, confidence=0.95, timestamp=stamp
            )
            node.note(
                OBSTACLE,
                "bearing",
                round(math.atan2(dy, dx) - heading, 6),
                accuracy=0.01,
                confidence=0.95,
                timestamp=stamp,
            )
            await node.flush()
        print("Proximity: done", flush=True)


if __name__ == "__main__":
    args = arguments(__doc__ or "")
    asyncio.run(run(args.host, args.port))
