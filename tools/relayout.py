"""Rewrite module paths after the #17 layout moves (one-off, kept so late edits can be rerun).

`python tools/relayout.py FILE...` rewrites, in place, every dotted module path
(`openair.codec` -> `openair.protocol.codec`, `openair.server.router` ->
`openair.server.core.router`), every source path (`reference/openair/server/app.py` ->
`reference/openair/server/aio/app.py`) and every `from openair[.server] import a, b` line (split
by the package each name now lives in). Without arguments it rewrites every file git knows
(tracked or untracked, not ignored) except test-artifacts/ (records of past runs).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

PROTOCOL = [
    "framing",
    "xmlsafe",
    "codec",
    "fastcodec",
    "message",
    "types",
    "matching",
    "content",
    "contentmatch",
    "objects",
    "registration",
    "wakeup",
    "errors",
    "_errors_base",
    "datasample",
    "auth",
    "address",
    "times",
    "attachments",
]
CORE = [
    "router",
    "sessions",
    "whiteboard",
    "retrieve",
    "streams",
    "streamservice",
    "queues",
    "store",
    "config",
    "commands",
    "contexts",
    "budgets",
    "auth",
]
AIO = ["app", "protocol", "delivery", "internal", "pusher", "scheduling", "datapath"]

MOVES: dict[str, str] = {f"openair.{m}": f"openair.protocol.{m}" for m in PROTOCOL}
MOVES |= {f"openair.server.{m}": f"openair.server.core.{m}" for m in CORE}
MOVES |= {f"openair.server.{m}": f"openair.server.aio.{m}" for m in AIO}

_names = sorted(MOVES, key=len, reverse=True)
DOTTED = re.compile(r"(?<![\w.])(" + "|".join(re.escape(n) for n in _names) + r")(?![\w])")
_paths = {k.replace(".", "/"): v.replace(".", "/") for k, v in MOVES.items()}
_pnames = sorted(_paths, key=len, reverse=True)
# A source path: `openair/x.py`, or a folder (`openair/server/datapath/`); never `.hpp` etc.
SLASHED = re.compile(
    r"(?<![\w.-])((?:[\w.-]+/)*)(" + "|".join(re.escape(n) for n in _pnames) + r")(?=\.pyi?\b|/)"
)
_bare = sorted((k.split(".", 2)[2] for k in MOVES if k.startswith("openair.server.")), key=len)
# `server/router.py` written without the package path (README, design notes, docstrings).
BARE_SERVER = re.compile(r"(?<![\w/.-])server/(" + "|".join(reversed(_bare)) + r")(?=\.pyi?\b|/)")
FROM_IMPORT = re.compile(r"^(\s*)from (openair|openair\.server) import ([\w ,]+?)\s*$", re.M)


def _split_from(match: re.Match[str]) -> str:
    indent, package, names = match.group(1), match.group(2), match.group(3)
    groups: dict[str, list[str]] = {}
    for item in (n.strip() for n in names.split(",")):
        if not item:
            continue
        target = MOVES.get(f"{package}.{item.split()[0]}")
        home = target.rsplit(".", 1)[0] if target else package
        groups.setdefault(home, []).append(item)
    return "\n".join(
        f"{indent}from {home} import {', '.join(items)}" for home, items in groups.items()
    )


def rewrite(text: str) -> str:
    """Return `text` with every moved module path rewritten."""
    text = FROM_IMPORT.sub(_split_from, text)
    text = DOTTED.sub(lambda m: MOVES[m.group(1)], text)
    text = SLASHED.sub(lambda m: m.group(1) + _paths[m.group(2)], text)
    return BARE_SERVER.sub(
        lambda m: _paths["openair/server/" + m.group(1)][len("openair/") :], text
    )


def _files() -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files", "-co", "--exclude-standard"], capture_output=True, text=True, check=True
    ).stdout.split("\n")
    return [
        Path(p)
        for p in out
        if p and not p.startswith(("test-artifacts/", ".brief/")) and p != "tools/relayout.py"
    ]


def main(argv: list[str]) -> int:
    changed = 0
    for path in [Path(a) for a in argv] or _files():
        if path.is_symlink() or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        new = rewrite(text)
        if new != text:
            path.write_text(new, encoding="utf-8")
            print(path)
            changed += 1
    print(f"{changed} files rewritten", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
