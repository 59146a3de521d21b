"""Rob0Vision: Skundar's camera, streamed off-board as compressed frames.

A synthetic camera (60 degree field of view) looks ahead of the simulated robot: the goal is
a bright marker whose column follows its bearing and whose size grows as it comes closer.
Each frame is a 160x120 grayscale baseline JPEG (skundar_jpeg), written to the `Camera` stream
(type `Skundar.Input.Video.Camera`) at the sensor's 10 Hz. The camera sees the simulated world:
it reads the true pose (`Skundar.Sim.Pose`) and the goal (`Skundar.Decision.Cmd2dMove`).
"""

from __future__ import annotations

import math

from skundar_common import (
    CAMERA,
    CMD_MOVE,
    DECISION,
    POSE_TRUTH,
    SIM,
    kv,
    ready,
    run_module,
    server_address,
    wrap,
)
from skundar_jpeg import encode

from openair.client import Module
from openair.protocol.content import Trigger

COLS, ROWS = 20, 15  # 8x8 blocks: 160x120 pixels
FOV = math.radians(60)


def render(x: float, y: float, th: float, goal: tuple[float, float] | None) -> list[list[int]]:
    """Draw the view: sky, floor, and the goal marker when it is in the field of view."""
    blocks = [[60 if r < ROWS // 2 else 90 + 4 * r for _ in range(COLS)] for r in range(ROWS)]
    if goal is None:
        return blocks
    bearing = wrap(math.atan2(goal[1] - y, goal[0] - x) - th)
    if abs(bearing) >= FOV / 2:
        return blocks
    col = int((0.5 - bearing / FOV) * COLS)
    half = max(0, min(3, int(0.6 / max(0.2, math.hypot(goal[0] - x, goal[1] - y)))))
    for r in range(ROWS // 2 - 1 - half, ROWS // 2 + 1 + half):
        for c in range(col - half, col + half + 1):
            if 0 <= r < ROWS and 0 <= c < COLS:
                blocks[r][c] = 250
    return blocks


async def main() -> None:
    """Stream frames until stopped."""
    host, port = server_address()
    goal: tuple[float, float] | None = None
    async with Module("Rob0Vision", host, port) as module:
        sees = [Trigger(pattern=POSE_TRUTH, whiteboard=SIM)]
        await module.subscribe([*sees, Trigger(pattern=CMD_MOVE, whiteboard=DECISION)])
        camera = module.stream(CAMERA)
        ready()
        async for event in module.wakeups():
            msg = event.wakeup.trigger
            if msg is None:
                continue
            values = kv(msg.content)
            if msg.type == CMD_MOVE:
                goal = (float(values["x"]), float(values["y"]))
                continue
            x, y, th = (float(values[k]) for k in ("x", "y", "th"))
            frame = encode(render(x, y, th, goal))
            params = {"builtin:width": "160", "builtin:height": "120", "t": values["t"]}
            await camera.add(frame, params, noreply=True, seq=int(values["seq"]))


if __name__ == "__main__":
    run_module(main)
