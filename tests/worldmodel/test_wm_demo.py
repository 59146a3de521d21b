"""The demo runs end to end as separate processes through `openair serve` (bounded)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

DEMO = Path(__file__).resolve().parents[2] / "examples" / "worldmodel" / "run_demo.py"


def test_demo_plan_fires_and_terminates() -> None:
    done = subprocess.run(
        [sys.executable, str(DEMO), "--bound", "60"],
        capture_output=True,
        text=True,
        timeout=150,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    acks = [
        line.split(": ", 1)[1].split()[0]
        for line in done.stdout.splitlines()
        if line.startswith("[ack]")
    ]
    assert acks == ["accepted", "initiated", "fired", "terminated"]
    assert "Locomotion: STOP" in done.stdout
