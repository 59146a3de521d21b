"""Names, units and helpers shared by Skundar's Python modules (seed paper, Figures 1 and 2).

Contents are `key=value;key=value` text, so the C++ and Java modules read them without an XML
parser. Every message of the control loop carries `t`, the wall-clock time (ms since the epoch)
at which the simulated mouse sensor was sampled, and `seq`, the sample's number: the controller
measures its loop latency from them.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import signal
import time
from collections.abc import Callable, Coroutine
from dataclasses import dataclass

# Whiteboards (figure1.psySpec.xml, figure2.psySpec.xml).
PERCEPTION = "PerceptionWB"
DECISION = "DecisionWB"
MOTOR = "MotorWB"
SIM = "SimWB"
LOAD = "LoadWB"

# Message types (skundar.ontology.xml).
MOUSE_SENSOR = "Skundar.Sim.MouseSensor"
POSE_TRUTH = "Skundar.Sim.Pose"
MOUSE_MOTION = "Skundar.Input.Sens.MouseMotion"
TRACK = "Skundar.Input.Perc.Track"
MARKER = "Skundar.Input.Perc.Vision.Marker"
CMD_MOVE = "Skundar.Decision.Cmd2dMove"
DIFF_MOTION = "Skundar.Output.Motor.DiffMotion"
WHEEL_SPEEDS = "Skundar.Output.Motor.WheelSpeeds"
CAMERA = "Camera"  # the stream (type Skundar.Input.Video.Camera)

#: Optical mouse resolution: 400 counts per inch.
COUNTS_PER_M = 400 / 0.0254
#: The gyro reports heading changes in microradians.
GYRO_PER_RAD = 1_000_000
#: Distance between the wheels (m).
WHEEL_BASE = 0.30
#: The sensor (and so the control loop) runs at 10 Hz, as Rob0Mouse in the paper.
SENSOR_PERIOD_S = 0.1


def kv(content: str) -> dict[str, str]:
    """Parse `a=1;b=2` into a dict (unknown keys are kept, empty parts ignored)."""
    out: dict[str, str] = {}
    for part in content.split(";"):
        key, sep, value = part.partition("=")
        if sep:
            out[key.strip()] = value.strip()
    return out


def fmt(**values: float | int | str) -> str:
    """Write `a=1;b=2` with floats at 6 decimals."""
    return ";".join(
        f"{k}={v:.6f}" if isinstance(v, float) else f"{k}={v}" for k, v in values.items()
    )


def now_ms() -> float:
    """Wall-clock milliseconds since the epoch (every module is on this machine)."""
    return time.time() * 1000.0


def wrap(angle: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


@dataclass(slots=True, kw_only=True)
class Pose:
    """A planar pose: metres and radians."""

    x: float = 0.0
    y: float = 0.0
    th: float = 0.0

    def advance(self, dx: float, dy: float, dth: float) -> None:
        """Add a body-frame displacement measured since the last update."""
        c, s = math.cos(self.th), math.sin(self.th)
        self.x += c * dx - s * dy
        self.y += s * dx + c * dy
        self.th = wrap(self.th + dth)


def server_address() -> tuple[str, int]:
    """The server from SKUNDAR_HOST / SKUNDAR_PORT (the demo runner sets them)."""
    return os.environ.get("SKUNDAR_HOST", "127.0.0.1"), int(os.environ.get("SKUNDAR_PORT", "10000"))


async def wait_forever() -> None:
    """Sleep until cancelled (the runner stops a module with SIGTERM)."""
    await asyncio.Event().wait()


def ready() -> None:
    """Tell the demo runner this module is registered and running."""
    print("ready", flush=True)


def run_module(main: Callable[[], Coroutine[object, object, None]]) -> None:
    """Run a module's coroutine until it ends or SIGTERM/SIGINT arrives (then close cleanly)."""

    async def guarded() -> None:
        task = asyncio.ensure_future(main())
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, task.cancel)
        with contextlib.suppress(asyncio.CancelledError):
            await task

    asyncio.run(guarded())
