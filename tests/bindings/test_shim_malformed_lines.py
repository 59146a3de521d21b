"""OA-GEN-5 in every binding's shim: what it answers to command lines it cannot run.

A line that is a JSON object with a non-negative integer `seq` but an unknown `cmd` or a wrongly
typed field gets an API_MISUSE failure with that `seq`; a line that cannot be paired with a
command (not JSON, not an object, no usable `seq`) gets nothing on standard output and a note on
standard error; either way the shim goes on and answers the next command.

The C++ and Java shims come from `make cpp` and `make java` (skipped without them unless
OPENAIR_REQUIRE_BINDINGS=1, as `make test` sets).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from bindings_support import require

ROOT = Path(__file__).resolve().parents[2]
CPP_SHIM = ROOT / "bindings" / "cpp" / "build" / "openair-shim"
JAVA_SHIM = ROOT / "bindings" / "java" / "target" / "openair-shim.jar"

UNPAIRABLE = (
    "this is not json",
    "[1, 2, 3]",
    '"a string"',
    '{"cmd": "close"}',
    '{"seq": -1, "cmd": "close"}',
    '{"seq": "7", "cmd": "close"}',
    '{"seq": 1.5, "cmd": "close"}',
)
MISUSED = (
    '{"seq": 11, "cmd": "no-such-command"}',
    '{"seq": 12}',
    '{"seq": 13, "cmd": "connect", "port": "not a number"}',
)


def _command(key: str) -> list[str]:
    if key == "python":
        return [sys.executable, "-m", "openair.client.shim"]
    if key == "cpp":
        require("bindings", "make cpp", CPP_SHIM)
        return [str(CPP_SHIM)]
    require("bindings", "make java", JAVA_SHIM, java=True)
    return [shutil.which("java") or "java", "-jar", str(JAVA_SHIM)]


@pytest.mark.parametrize("key", ["python", "cpp", "java"])
def test_shim_answers_only_what_it_can_pair(key: str) -> None:
    lines = [*UNPAIRABLE, *MISUSED, '{"seq": 20, "cmd": "close"}']
    done = subprocess.run(
        _command(key),
        input="\n".join(lines) + "\n",
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    out = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    assert out[0].get("event") == "ready", out
    answers = out[1:]
    assert [a.get("seq") for a in answers] == [11, 12, 13, 20], answers
    for answer in answers[:3]:
        assert answer["ok"] is False, answer
        assert answer["error"]["code"] == "API_MISUSE", answer
    assert answers[3]["ok"] is True, answers[3]
    # Every unpairable line leaves a note on standard error.
    notes = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(notes) >= len(UNPAIRABLE), done.stderr
