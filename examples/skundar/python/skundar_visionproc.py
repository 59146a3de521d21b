"""Rob0VisionProc: off-board vision — read the camera stream, post where the marker is.

Subscribes to the `Camera` stream (push), decodes each JPEG frame (skundar_jpeg), finds the
bright marker's column and posts `Skundar.Input.Perc.Vision.Marker` (bearing in radians,
positive to the left, `seen=0` when the marker is out of view) to PerceptionWB.
"""

from __future__ import annotations

import math

from skundar_common import CAMERA, MARKER, PERCEPTION, fmt, ready, run_module, server_address
from skundar_jpeg import JpegError, decode_dc

from openair.client import Module

FOV = math.radians(60)
BRIGHT = 200


def find_marker(blocks: list[list[int]]) -> float | None:
    """Return the marker's bearing (radians, left positive), or None when none is seen."""
    cols = [c for row in blocks for c, v in enumerate(row) if v >= BRIGHT]
    if not cols:
        return None
    centre = (min(cols) + max(cols) + 1) / 2
    return (0.5 - centre / len(blocks[0])) * FOV


async def main() -> None:
    """Process frames until stopped."""
    host, port = server_address()
    async with Module("Rob0VisionProc", host, port) as module:
        frames = module.subscribe_stream(CAMERA, buffer=20)
        await frames.open()  # confirmed: the server counts this subscriber
        ready()
        async for got in frames:
            params = dict(got.sample.params)
            try:
                bearing = find_marker(decode_dc(bytes(got.sample.payload)))
            except JpegError as exc:
                print(f"Rob0VisionProc: unreadable frame: {exc}", flush=True)
                continue
            seen = fmt(seen=0) if bearing is None else fmt(seen=1, bearing=bearing)
            content = f"{seen};t={params.get('t', '')};dropped={got.dropped}"
            await module.post(PERCEPTION, MARKER, content, noreply=True)


if __name__ == "__main__":
    run_module(main)
