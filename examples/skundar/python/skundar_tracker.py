"""Rob0Tracker (Figure 1): integrate the mouse's motion into the robot's tracked pose.

Woken by each `Skundar.Input.Sens.MouseMotion` of the C++ Rob0Mouse; posts
`Skundar.Input.Perc.Track` (x, y, heading, and the sample's `t`/`seq` passed on).
"""

from __future__ import annotations

from skundar_common import (
    MOUSE_MOTION,
    PERCEPTION,
    TRACK,
    Pose,
    fmt,
    kv,
    ready,
    run_module,
    server_address,
)

from openair.client import Module
from openair.protocol.content import Trigger


def track_content(pose: Pose, motion: dict[str, str]) -> str:
    """Advance the pose by one MouseMotion and write the Track content."""
    pose.advance(float(motion["dx"]), float(motion["dy"]), float(motion["dth"]))
    return fmt(x=pose.x, y=pose.y, th=pose.th, t=motion["t"], seq=motion["seq"])


async def main() -> None:
    """Track until stopped."""
    host, port = server_address()
    pose = Pose()
    async with Module("Rob0Tracker", host, port) as module:
        await module.subscribe([Trigger(pattern=MOUSE_MOTION, whiteboard=PERCEPTION)])
        ready()
        async for event in module.wakeups():
            trigger = event.wakeup.trigger
            if trigger is not None:
                await module.post(PERCEPTION, TRACK, track_content(pose, kv(trigger.content)))


if __name__ == "__main__":
    run_module(main)
