"""Run Skundar as in the seed paper: Figure 1 (before), then Figure 2 (after); compare them.

For each figure: start the reference server with the figure's psySpec, start the modules as
processes (C++ Rob0Mouse and Rob0MotorControl, Java Rob0MotionControl, Python Rob0Tracker,
Rob0Vision, Rob0VisionProc and the simulated plant; in Figure 2 the merged Mouse+Tracker runs
inside the server), send a `Cmd2dMove` goal, and measure while the robot drives to it:
message rates per type, post→wakeup latency (the monitor's histograms), server CPU, and the
controller's loop latency against its deadline. `--load N` adds N background posters.

Exit status: 0 when the robot reached the goal in every figure run; 1 otherwise; 3 when a
build, the server or a module did not start.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import os
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import skundar_measure as measure
from skundar_common import (
    CMD_MOVE,
    DECISION,
    DIFF_MOTION,
    MOTOR,
    PERCEPTION,
    POSE_TRUTH,
    SIM,
    TRACK,
    fmt,
    kv,
)

from openair.client import Module
from openair.protocol.content import RetrieveSpec

HERE = Path(__file__).resolve().parent
SKUNDAR = HERE.parent
ROOT = SKUNDAR.parent.parent
CPP_BUILD = SKUNDAR / "cpp" / "build"
JAVA = SKUNDAR / "java"
OPENAIR_JAR = Path.home() / ".m2/repository/org/openair/openair/0.1.0/openair-0.1.0.jar"
#: How long the robot may take to stop after it came within the tolerance.
SETTLE_S = 1.5
#: (whiteboard, type) of every message the demo counts.
COUNTED = (
    ("SimWB", "Skundar.Sim.MouseSensor"),
    ("SimWB", "Skundar.Sim.Pose"),
    ("PerceptionWB", "Skundar.Input.Sens.MouseMotion"),
    ("PerceptionWB", "Skundar.Input.Perc.Track"),
    ("PerceptionWB", "Skundar.Input.Perc.Vision.Marker"),
    ("MotorWB", "Skundar.Output.Motor.DiffMotion"),
    ("MotorWB", "Skundar.Output.Motor.WheelSpeeds"),
)
MODULES = {
    1: ["Rob0Plant", "Rob0Mouse", "Rob0Tracker", "Rob0MotionControl", "Rob0MotorControl",
        "Rob0Vision", "Rob0VisionProc"],
    2: ["Rob0Plant", "Rob0MouseTracker", "Rob0MotionControl", "Rob0MotorControl",
        "Rob0Vision", "Rob0VisionProc"],
}  # fmt: skip


@dataclass(slots=True, kw_only=True)
class Result:
    """What one figure's run measured."""

    figure: int
    load: int
    window_s: float = 0.0
    rates: dict[str, float] = field(default_factory=dict)
    hop_p50_ms: float | None = None
    hop_p99_ms: float | None = None
    loop_p50_ms: float | None = None
    loop_p99_ms: float | None = None
    cycles: int = 0
    misses: int = 0
    kept_deadline: bool = False
    server_cpu_pct: float = 0.0
    reached: bool = False
    reach_s: float | None = None
    final_error_m: float | None = None
    odometry_error_m: float | None = None
    watchdog_stops: int = 0
    loadavg: str = ""


class Child:
    """A module process; its output is kept and shown when something goes wrong."""

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
        """SIGTERM, then SIGKILL after 5 s."""
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


def build() -> None:
    """Build the C++ modules and the Java controller (incremental; offline Maven).

    The Java client is installed into ~/.m2 when it is not there yet (`make demo-skundar`
    always installs it afresh).
    """
    cfg = ["cmake", "-S", str(SKUNDAR / "cpp"), "-B", str(CPP_BUILD), "-DCMAKE_BUILD_TYPE=Release"]
    subprocess.run(cfg, check=True, stdout=subprocess.DEVNULL)
    subprocess.run(
        ["cmake", "--build", str(CPP_BUILD), "-j2"], check=True, stdout=subprocess.DEVNULL
    )
    if not OPENAIR_JAR.is_file():  # the Java client, into the local Maven repository
        install = ["mvn", "-o", "-q", "install", "-DskipTests"]
        subprocess.run(install, cwd=ROOT / "bindings" / "java", check=True)
    subprocess.run(["mvn", "-o", "-q", "package"], cwd=JAVA, check=True)


def commands(figure: int, load: int) -> list[tuple[str, list[str]]]:
    """The module processes of a figure (name, argv)."""
    py = [sys.executable]
    java = ["java", "-cp", f"{JAVA / 'target/classes'}{os.pathsep}{OPENAIR_JAR}"]
    procs = [
        ("Rob0Plant", [*py, str(HERE / "skundar_plant.py")]),
        ("Rob0MotionControl", [*java, "org.openair.skundar.MotionControl"]),
        ("Rob0MotorControl", [str(CPP_BUILD / "skundar_motor_control")]),
        ("Rob0Vision", [*py, str(HERE / "skundar_vision.py")]),
        ("Rob0VisionProc", [*py, str(HERE / "skundar_visionproc.py")]),
    ]
    if figure == 1:
        procs += [
            ("Rob0Mouse", [str(CPP_BUILD / "skundar_mouse")]),
            ("Rob0Tracker", [*py, str(HERE / "skundar_tracker.py")]),
        ]
    return procs + [(f"Load{i}", [*py, str(HERE / "skundar_load.py"), str(i)]) for i in range(load)]


def environment(port: int, deadline_ms: float) -> dict[str, str]:
    """The children's environment: the server's address, the deadline, this folder on the path."""
    env = dict(os.environ)
    env.update(
        SKUNDAR_HOST="127.0.0.1", SKUNDAR_PORT=str(port), SKUNDAR_DEADLINE_MS=str(deadline_ms)
    )
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE), env.get("PYTHONPATH", "")) if p)
    return env


async def start_server(figure: int, port: int, env: dict[str, str]) -> tuple[Child, int]:
    """Start `openair serve` with the figure's psySpec; return it and its port."""
    openair = Path(sys.executable).parent / "openair"
    spec = SKUNDAR / f"figure{figure}.psySpec.xml"
    proc = await asyncio.create_subprocess_exec(
        str(openair), "serve", "--config", str(spec), "--host", "127.0.0.1", "--port", str(port),
        "--log-level", "error", stdout=asyncio.subprocess.PIPE, env=env,
    )  # fmt: skip
    assert proc.stdout is not None
    async with asyncio.timeout(20):
        line = (await proc.stdout.readline()).decode()
    if not line.startswith("listening on "):
        raise RuntimeError(f"the server did not start: {line!r}")
    return Child("server", proc), int(line.split()[2].rsplit(":", 1)[1])


async def true_pose(
    operator: Module, wb: str = SIM, type_: str = POSE_TRUTH
) -> tuple[float, float] | None:
    """The simulated robot's latest true position (or, with TRACK, its tracked one)."""
    found = await operator.retrieve(RetrieveSpec(whiteboard=wb, pattern=type_, latest=1))
    if not found:
        return None
    values = kv(found[0].content)
    return float(values["x"]), float(values["y"])


async def count_window(operator: Module, window_ms: int) -> dict[tuple[str, str], list[str]]:
    """The contents of every counted message posted in the last window_ms, by (wb, type)."""
    out: dict[tuple[str, str], list[str]] = {}
    for wb, type_ in COUNTED:
        spec = RetrieveSpec(whiteboard=wb, pattern=type_, latest=0, lastmsec=window_ms)
        out[(wb, type_)] = [m.content for m in await operator.retrieve(spec)]
    return out


@dataclass(slots=True, kw_only=True)
class Settings:
    """The command line."""

    port: int
    seconds: float
    bound: float
    load: int
    deadline_ms: float
    goal: tuple[float, float]
    tolerance: float


async def drive(operator: Module, server: Child, base: str, figure: int, s: Settings) -> Result:
    """Send the goal and measure until `seconds` passed and the goal was reached (or `bound`)."""
    result = Result(figure=figure, load=s.load)
    loop = asyncio.get_running_loop()
    before = await asyncio.to_thread(measure.snapshot, base, MODULES[figure])
    cpu0, start = measure.cpu_seconds(server.proc.pid), loop.time()
    await operator.post(DECISION, CMD_MOVE, fmt(x=s.goal[0], y=s.goal[1]))
    while (elapsed := loop.time() - start) < s.bound:
        pose = await true_pose(operator)
        if pose is not None:
            result.final_error_m = math.hypot(pose[0] - s.goal[0], pose[1] - s.goal[1])
            if not result.reached and result.final_error_m <= s.tolerance:
                result.reached, result.reach_s = True, round(elapsed, 2)
        if result.reached and elapsed >= max(s.seconds, (result.reach_s or 0) + SETTLE_S):
            break  # measured long enough, and the robot had time to come to rest
        await asyncio.sleep(0.2)
    result.window_s = loop.time() - start
    track, pose = await true_pose(operator, PERCEPTION, TRACK), await true_pose(operator)
    if track is not None and pose is not None:
        result.odometry_error_m = math.hypot(track[0] - pose[0], track[1] - pose[1])
    result.server_cpu_pct = 100 * (measure.cpu_seconds(server.proc.pid) - cpu0) / result.window_s
    after = await asyncio.to_thread(measure.snapshot, base, MODULES[figure])
    summarize(result, before, after, await count_window(operator, int(result.window_s * 1000)))
    result.kept_deadline = result.cycles > 0 and result.misses <= 0.01 * result.cycles
    result.loadavg = " ".join(f"{x:.2f}" for x in os.getloadavg())
    return result


def summarize(
    result: Result,
    before: measure.Snapshot,
    after: measure.Snapshot,
    window: dict[tuple[str, str], list[str]],
) -> None:
    """Fill in rates and latencies from the counters and the history of the window."""
    w = result.window_s
    for (_, type_), contents in window.items():
        result.rates[type_] = round(len(contents) / w, 1)
    for name, added in after.samples_added.items():
        result.rates[f"stream {name} (JPEG frames)"] = round(
            (added - before.samples_added.get(name, 0)) / w, 1
        )
    load = after.received.get("LoadWB", 0) - before.received.get("LoadWB", 0)
    result.rates["Load.Noise (background)"] = round(load / w, 1)
    hist = measure.histogram_delta(before, after)
    result.hop_p50_ms = measure.histogram_quantile(hist, 0.50)
    result.hop_p99_ms = measure.histogram_quantile(hist, 0.99)
    lats, result.misses = measure.loop_latencies(window[(MOTOR, DIFF_MOTION)])
    result.cycles = len(lats)
    result.loop_p50_ms = measure.quantile(lats, 0.50)
    result.loop_p99_ms = measure.quantile(lats, 0.99)


async def run_figure(figure: int, s: Settings) -> Result:
    """Start the server and the modules of one figure, drive, stop everything."""
    env = environment(s.port, s.deadline_ms)
    server, port = await start_server(figure, s.port, env)
    env["SKUNDAR_PORT"] = str(port)
    base = f"http://127.0.0.1:{port}"
    print(f"[figure {figure}] server on 127.0.0.1:{port}; monitor (live): {base}/", flush=True)
    children: list[Child] = []
    try:
        for name, argv in commands(figure, s.load):
            proc = await asyncio.create_subprocess_exec(
                *argv,
                stdout=asyncio.subprocess.PIPE,
                stderr=asyncio.subprocess.STDOUT,  # kept, shown when a module fails to start
                env=env,
                cwd=str(ROOT),
            )
            children.append(Child(name, proc))
        async with asyncio.timeout(30):
            await asyncio.gather(*(c.ready.wait() for c in children))
        print(f"[figure {figure}] {len(children)} module processes ready", flush=True)
        if s.load:
            await asyncio.sleep(1.0)  # let the background traffic build up
        async with Module("Rob0Operator", "127.0.0.1", port, listen=False) as operator:
            result = await drive(operator, server, base, figure, s)
    except TimeoutError:
        for child in children:
            if not child.ready.is_set():
                print(f"[figure {figure}] {child.name} not ready: {child.lines[-5:]}", flush=True)
        raise
    finally:
        for child in children:
            await child.stop()
        await server.stop()
        watchdog = [c for c in children if c.name == "Rob0MotorControl"]
        stops = sum("watchdog stop" in line for c in watchdog for line in c.lines)
    result.watchdog_stops = stops
    return result


def _mm(metres: float | None) -> str:
    return "-" if metres is None else f"{metres * 1000:.0f} mm"


def show(results: list[Result], deadline_ms: float) -> None:
    """Print the before/after table."""

    def ms(v: float | None) -> str:
        return "-" if v is None else f"{v:.1f}"

    heads = [f"Figure {r.figure}" + (" (before)" if r.figure == 1 else " (after)") for r in results]
    rows: list[tuple[str, list[str]]] = []
    for key in results[0].rates:
        rows.append((f"rate {key} /s", [f"{r.rates.get(key, 0):.1f}" for r in results]))
    rows += [
        ("post→wakeup p50 / p99 ms", [f"{ms(r.hop_p50_ms)} / {ms(r.hop_p99_ms)}" for r in results]),
        ("sensor→command p50 / p99 ms", [
            f"{ms(r.loop_p50_ms)} / {ms(r.loop_p99_ms)}" for r in results]),
        (f"deadline {deadline_ms:g} ms kept", [
            f"{'yes' if r.kept_deadline else 'NO'} ({r.misses}/{r.cycles} late)" for r in results]),
        ("tracked vs true position", [_mm(r.odometry_error_m) for r in results]),
        ("motor watchdog stops", [str(r.watchdog_stops) for r in results]),
        ("server CPU % of a core", [f"{r.server_cpu_pct:.0f}" for r in results]),
        ("goal reached (after s), final error", [
            f"{'yes' if r.reached else 'NO'} ({r.reach_s}), {_mm(r.final_error_m)}"
            for r in results]),
        ("load average after", [r.loadavg for r in results]),
    ]  # fmt: skip
    print(f"\n| measure (background posters: {results[0].load}) | " + " | ".join(heads) + " |")
    print("|---|" + "---|" * len(results))
    for label, cells in rows:
        print(f"| {label} | " + " | ".join(cells) + " |")


def write_site(out: Path) -> None:
    """Generate the ontology site (type tree, a page per type, modules ↔ whiteboards ↔ types)."""
    openair = Path(sys.executable).parent / "openair"
    subprocess.run(
        [str(openair), "ontology", "docs", str(SKUNDAR / "skundar.ontology.xml"),
         "--psyspec", str(SKUNDAR / "figure1.psySpec.xml"), "-o", str(out)],
        check=True, stdout=subprocess.DEVNULL,
    )  # fmt: skip
    print(f"ontology site: {out / 'index.html'}", flush=True)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0] if __doc__ else None)
    p.add_argument("--figure", choices=("1", "2", "both", "none"), default="both")
    p.add_argument("--port", type=int, default=0, help="server port (0: any free one)")
    p.add_argument("--seconds", type=float, default=10.0, help="measure at least this long")
    p.add_argument("--bound", type=float, default=30.0, help="give up on the goal after this")
    p.add_argument("--load", type=int, default=0, metavar="N", help="N background posters")
    p.add_argument(
        "--ramp",
        action="store_true",
        help="add posters one by one (up to --load) until Figure 1 misses; then run Figure 2",
    )
    p.add_argument(
        "--deadline-ms", type=float, default=100.0, help="loop deadline: the sensor period"
    )
    p.add_argument("--goal", default="1.0,0.5", help="X,Y in metres")
    p.add_argument("--tolerance", type=float, default=0.1, help="goal reached within (m)")
    p.add_argument("--build", action="store_true", help="build the C++ and Java modules first")
    p.add_argument("--site", type=Path, default=SKUNDAR / "site", help="ontology site folder")
    p.add_argument("--no-site", action="store_true", help="do not generate the ontology site")
    p.add_argument("--json", type=Path, help="write the results as JSON")
    return p.parse_args(argv)


async def ramp(s: Settings) -> list[Result]:
    """Run Figure 1 with 0, 1, … `s.load` posters until it misses its deadline; then Figure 2."""
    top, one = s.load, None
    for n in range(top + 1):
        s.load = n
        one = await run_figure(1, s)
        print(f"[ramp] {n} background posters: Figure 1 kept its deadline: "
              f"{one.kept_deadline} ({one.misses}/{one.cycles} late)", flush=True)  # fmt: skip
        if not one.kept_deadline:
            break
    assert one is not None
    return [one, await run_figure(2, s)]


async def amain(args: argparse.Namespace) -> int:
    """Run the figures asked for, print the table, return the exit status."""
    x, y = (float(v) for v in args.goal.split(","))
    settings = Settings(
        port=args.port, seconds=args.seconds, bound=args.bound, load=args.load,
        deadline_ms=args.deadline_ms, goal=(x, y), tolerance=args.tolerance,
    )  # fmt: skip
    figures = [1, 2] if args.figure == "both" else [int(args.figure)]
    try:
        if args.ramp:
            results = await ramp(settings)
        else:
            results = [await run_figure(figure, settings) for figure in figures]
    except (RuntimeError, TimeoutError) as exc:
        print(f"run_demo: a figure did not start: {exc!r}", file=sys.stderr)
        return 3
    show(results, args.deadline_ms)
    if args.json is not None:
        args.json.write_text(json.dumps([asdict(r) for r in results], indent=2))
    return 0 if all(r.reached for r in results) else 1


def main(argv: list[str] | None = None) -> int:
    """Build (optionally), write the ontology site, run the demo."""
    args = parse_args(argv)
    try:
        if args.build:
            build()
        if not args.no_site:
            write_site(args.site)
    except (OSError, subprocess.CalledProcessError) as exc:
        print(f"run_demo: {exc}", file=sys.stderr)
        return 3
    if args.figure == "none":  # build and site only
        return 0
    started = time.monotonic()
    status = asyncio.run(amain(args))
    print(f"run_demo: {time.monotonic() - started:.1f} s", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
