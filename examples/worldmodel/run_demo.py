"""Run the world-model demo: server, four module processes, a planner; print the plan's trace.

Exit status: 0 when the plan was accepted, initiated, fired and terminated within the bound;
1 otherwise (the trace says where it stopped); 3 when the server did not start.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import sys
from pathlib import Path

from wm_common import OBSTACLE, PLAN, POSE, ROBOT, STOP_CLEARANCE, WHITEBOARD

from openair_worldmodel import ControlAction, Plan, parse_condition
from openair_worldmodel.node import WorldModelNode

HERE = Path(__file__).resolve().parent
MODULES = ("locomotion", "fusion", "nav", "proximity")
EXPECTED = ("accepted", "initiated", "fired", "terminated")


class Child:
    """A module process whose output is collected (and shown after the run)."""

    def __init__(self, name: str, proc: asyncio.subprocess.Process) -> None:
        self.name, self.proc, self.lines = name, proc, list[str]()
        self.ready = asyncio.Event()
        self.reader = asyncio.ensure_future(self._read())

    async def _read(self) -> None:
        assert self.proc.stdout is not None
        async for raw in self.proc.stdout:
            line = raw.decode(errors="replace").rstrip()
            if line == "ready":
                self.ready.set()
            else:
                self.lines.append(line)

    async def stop(self) -> None:
        if self.proc.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                self.proc.terminate()
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(5):
                await self.proc.wait()
        if self.proc.returncode is None:
            self.proc.kill()
            await self.proc.wait()
        self.reader.cancel()


async def start_server() -> tuple[asyncio.subprocess.Process, int]:
    """Start `openair serve` on a free port; return it and the port it announced."""
    openair = Path(sys.executable).parent / "openair"
    proc = await asyncio.create_subprocess_exec(
        str(openair),
        "serve",
        "--port",
        "0",
        "--no-monitor",
        "--log-level",
        "error",
        stdout=asyncio.subprocess.PIPE,
    )
    assert proc.stdout is not None
    async with asyncio.timeout(20):
        line = (await proc.stdout.readline()).decode()
    if not line.startswith("listening on "):
        raise RuntimeError(f"unexpected first line from the server: {line!r}")
    return proc, int(line.split()[2].rsplit(":", 1)[1])


def the_plan() -> Plan:
    """The plan of the demo: stop the vehicle when the obstacle comes within range."""
    return Plan(
        name=PLAN,
        initiation=parse_condition('Vehicle.state.value == "moving"'),
        trigger=parse_condition(f"{OBSTACLE}.clearance.value < {STOP_CLEARANCE}"),
        termination=parse_condition('Vehicle.state.value == "stopped"'),
        action=ControlAction(type="Loco.Stop"),
        origin="Planner",
        executor="Locomotion",
    )


def _world(node: WorldModelNode) -> str:
    bb = node.core.blackboard
    parts = [f"{o}.{a}" for o, a in ((POSE, "x"), (OBSTACLE, "x"), (OBSTACLE, "y"))]
    values = [bb.stored(*p.split(".")) for p in parts]
    return ", ".join(
        f"{p}={v.value}" if v else f"{p}=?" for p, v in zip(parts, values, strict=True)
    )


async def drive(host: str, port: int, bound: float) -> list[str]:
    """Send the plan, start the vehicle and collect the acknowledgements until final."""
    seen: list[str] = []
    async with WorldModelNode(
        "Planner", robot=ROBOT, whiteboard=WHITEBOARD, host=host, port=port
    ) as planner:
        await planner.send_plan(the_plan())
        print(f"[planner] sent plan {PLAN} to Locomotion", flush=True)
        loop = asyncio.get_running_loop()
        deadline = loop.time() + bound
        while (left := deadline - loop.time()) > 0:
            ack = await planner.next_ack(left)
            if ack is None:
                break
            seen.append(ack.ack.status)
            print(
                f"[ack] {ack.ack.plan}: {ack.ack.status} (fired {ack.ack.count})"
                + (f" reason={ack.ack.reason}" if ack.ack.reason else ""),
                flush=True,
            )
            if ack.ack.status == "accepted":
                await planner.module.post(WHITEBOARD, "Demo.Go")
                print("[planner] posted Demo.Go: the vehicle starts", flush=True)
            if ack.ack.status == "fired":
                print(f"[world] as the planner's replica sees it: {_world(planner)}", flush=True)
            if ack.ack.status in ("terminated", "failed"):
                break
    return seen


async def main(bound: float) -> int:
    try:
        server, port = await start_server()
    except (OSError, RuntimeError, TimeoutError) as exc:
        print(f"[demo] the server did not start: {exc}", file=sys.stderr)
        return 3
    print(f"[demo] openair serve listening on 127.0.0.1:{port}", flush=True)
    children: list[Child] = []
    try:
        for name in MODULES:
            proc = await asyncio.create_subprocess_exec(
                sys.executable,
                str(HERE / f"{name}.py"),
                "--port",
                str(port),
                stdout=asyncio.subprocess.PIPE,
            )
            children.append(Child(name, proc))
        async with asyncio.timeout(bound):
            await asyncio.gather(*(c.ready.wait() for c in children))
        print("[demo] modules ready: " + ", ".join(MODULES), flush=True)
        seen = await drive("127.0.0.1", port, bound)
    except TimeoutError:
        seen = []
        print("[demo] the modules did not get ready in time", flush=True)
    finally:
        for child in children:
            await child.stop()
        server.terminate()
        await server.wait()
    for child in children:
        for line in child.lines:
            print(f"[{child.name}] {line}")
    ok = [s for s in seen if s in EXPECTED] == list(EXPECTED)
    print("[demo] " + ("OK: the plan fired and terminated" if ok else f"FAILED: acks {seen}"))
    return 0 if ok else 1


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--bound", type=float, default=60.0, help="seconds to wait for the plan")
    sys.exit(asyncio.run(main(ap.parse_args().bound)))
