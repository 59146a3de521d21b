"""A stdlib-only shim that breaks `openair-shim/1` itself: `python fake_client_shim.py MODE`.

Modes: `bad-ready` (the first line is not a ready event), `garbage` (answers with a line that
is not JSON), `wrong-seq` (answers every command with another seq), `bad-answer` (answers
connect without `legacy`), `exit` (exits 1 on the first command), `silent` (never writes), and
`good` (says ready and answers close; every other command fails with API_MISUSE).
"""

from __future__ import annotations

import json
import sys

READY = {"event": "ready", "protocol": "openair-shim/1", "library": "fake", "version": "1.0"}


def _say(line: object) -> None:
    sys.stdout.write((line if isinstance(line, str) else json.dumps(line)) + "\n")
    sys.stdout.flush()


def _answer(mode: str, command: dict[str, object]) -> object:
    seq = command.get("seq", 0)
    if command.get("cmd") == "close":
        return {"seq": seq, "ok": True}
    if mode == "garbage":
        return "this is not JSON"
    if mode == "wrong-seq":
        return {"seq": int(str(seq)) + 1, "ok": True}
    if mode == "bad-answer" and command.get("cmd") == "connect":
        return {"seq": seq, "ok": True, "bound_port": -1}
    if mode == "exit":
        sys.exit(1)
    return {"seq": seq, "ok": False, "error": {"code": "API_MISUSE", "message": "fake"}}


def main(mode: str) -> int:
    if mode == "silent":
        sys.stdin.read()
        return 0
    _say({"event": "hello"} if mode == "bad-ready" else READY)
    for raw in sys.stdin:
        command = json.loads(raw)
        _say(_answer(mode, command))
        if command.get("cmd") == "close":
            break
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
