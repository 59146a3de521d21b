"""Rob0MouseTracker (Figure 2): Mouse and Tracker merged, running inside the server.

Named in figure2.psySpec.xml as `internal="skundar_internal:MouseTracker"` (the server needs
this folder on its PYTHONPATH; the demo runner sets it). Woken by the simulated sensor's
`Skundar.Sim.MouseSensor`, it converts the counts (Rob0Mouse's job) and integrates them
(Rob0Tracker's), then posts `Skundar.Input.Perc.Track` — routed in memory, no TCP, no XML.
"""

from __future__ import annotations

from typing import Protocol

from skundar_common import COUNTS_PER_M, GYRO_PER_RAD, PERCEPTION, TRACK, Pose, kv
from skundar_tracker import track_content

from openair.protocol.message import Message


class _Internal(Protocol):
    def trigger(self, msg: Message) -> Message | None: ...

    def post(self, to: str, type: str, content: str = "") -> Message | None: ...


def motion_of(sensor: dict[str, str]) -> dict[str, str]:
    """Convert the sensor's counts into a MouseMotion (metres, radians), as Rob0Mouse does."""
    return {
        "dx": str(int(sensor["cx"]) / COUNTS_PER_M),
        "dy": str(int(sensor["cy"]) / COUNTS_PER_M),
        "dth": str(int(sensor["gz"]) / GYRO_PER_RAD),
        "t": sensor["t"],
        "seq": sensor["seq"],
    }


class MouseTracker:
    """The internal module's handler: one instance, one pose."""

    def __init__(self) -> None:
        self.pose = Pose()

    async def __call__(self, module: _Internal, msg: Message) -> None:
        """Handle one delivery on the server's loop (never blocks)."""
        sensor = module.trigger(msg)
        if sensor is not None:
            module.post(PERCEPTION, TRACK, track_content(self.pose, motion_of(kv(sensor.content))))
