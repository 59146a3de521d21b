"""What the world-model demo's processes share: names, classes, the simulated world, arguments.

The demo (docs/worldmodel.md): a navigation sensor reports the robot's pose, a proximity sensor
reports the range and bearing of an obstacle, a fusion module turns them into the obstacle's
absolute position (an on-write active function), and the locomotion module runs a plan that stops
the vehicle when the obstacle's clearance (an on-read active function) is below a bound.
"""

from __future__ import annotations

import argparse
import math

from openair_worldmodel import Blackboard, ClassDef, FunctionRef, Packet, WMObject

ROBOT = "R1"
WHITEBOARD = "WB1"
VEHICLE = "Vehicle"  # SELF: state idle / moving / stopped
POSE = "Pose"  # SELF: x, y, heading (radians)
OBSTACLE = "Obstacle1"  # SURROUNDINGS: range, bearing (relative) and x, y (absolute)
TRUE_OBSTACLE = (5.0, 0.4)  # where the simulated obstacle really is
SENSOR_RANGE = 4.0
STEP = 0.25  # metres per navigation tick
STOP_CLEARANCE = 1.5
PLAN = "StopForObstacle"


def arguments(description: str) -> argparse.Namespace:
    """Read `--host` and `--port` (the reference server's address)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=10000)
    return ap.parse_args()


def _number(bb: Blackboard, obj: str, attribute: str) -> Packet | None:
    packet = bb.stored(obj, attribute)
    return packet if packet is not None and isinstance(packet.value, float) else None


def locate(bb: Blackboard, obj: WMObject, attribute: str, packet: Packet) -> None:
    """On-write function of range and bearing: derive the obstacle's absolute x and y."""
    parts = [_number(bb, obj.name, "range"), _number(bb, obj.name, "bearing")]
    parts += [_number(bb, POSE, a) for a in ("x", "y", "heading")]
    if any(p is None for p in parts):
        return
    rng, bearing, x, y, heading = (float(p.value) for p in parts if p is not None)  # type: ignore[arg-type]
    angle = heading + bearing
    stamp = max(p.timestamp for p in parts if p is not None)
    accuracy = max(p.accuracy for p in parts if p is not None)
    for name, value in (("x", x + rng * math.cos(angle)), ("y", y + rng * math.sin(angle))):
        bb.derive(
            obj.name,
            name,
            Packet(value=round(value, 6), accuracy=accuracy, confidence=0.9, timestamp=stamp),
        )


def clearance(
    bb: Blackboard, obj: WMObject, attribute: str, packet: Packet | None
) -> Packet | None:
    """On-read function of clearance: the distance from the robot to the obstacle, now."""
    parts = [_number(bb, obj.name, "x"), _number(bb, obj.name, "y")]
    parts += [_number(bb, POSE, "x"), _number(bb, POSE, "y")]
    if any(p is None for p in parts):
        return None
    ox, oy, rx, ry = (float(p.value) for p in parts if p is not None)  # type: ignore[arg-type]
    stamp = max(p.timestamp for p in parts if p is not None)
    return Packet(value=math.hypot(ox - rx, oy - ry), timestamp=stamp)


OBSTACLE_CLASS = ClassDef(
    name="Obstacle",
    attributes=(("range", None), ("bearing", None), ("x", None), ("y", None), ("clearance", None)),
)
FUSING_OBSTACLE = ClassDef(
    name="Obstacle",
    attributes=OBSTACLE_CLASS.attributes,
    functions=(
        FunctionRef(attribute="range", on="write", name="locate"),
        FunctionRef(attribute="bearing", on="write", name="locate"),
    ),
)
MEASURING_OBSTACLE = ClassDef(
    name="Obstacle",
    attributes=OBSTACLE_CLASS.attributes,
    functions=(FunctionRef(attribute="clearance", on="read", name="clearance"),),
)
