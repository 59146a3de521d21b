#!/usr/bin/env python3
"""Generate the session vectors (spec/vectors/sessions/*.json) from tools/sessionvectors/.

Usage: gen_session_vectors.py [--check]. With --check, exit 1 if a vector file is stale.

Every frame a client sends is rendered in the exact layout JavaOpenAIR writes (tab-indented,
`priority`/`timetolive` root attributes, lower-case `postedtime`), with the ids, names, times and
contents copied from the Psyclone wire transcripts (`psyclone-wire/NN-*.txt`); the README of the
vectors lists the origin of every frame. The transcripts are not read here or at test time. The
expected answers are the ones the spec requires, with the requirement IDs per step.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "spec" / "vectors" / "sessions"

sys.path.insert(0, str(ROOT))  # run as a script: make `tools.sessionvectors` importable
from tools.sessionvectors.common import Session  # noqa: E402
from tools.sessionvectors.s01_s03 import s01_connect_bind, s02_subscribe_post_wakeup, s03_cc  # noqa: E402
from tools.sessionvectors.s04_retrieve import s04_retrieve  # noqa: E402
from tools.sessionvectors.s05_registrations import s05_registration_forms  # noqa: E402
from tools.sessionvectors.s06_s07 import s06_self_and_multi, s07_errors  # noqa: E402
from tools.sessionvectors.s08_s09 import s08_keepalive_callback, s09_walkthrough  # noqa: E402

ALL_SESSIONS = (
    s01_connect_bind,
    s02_subscribe_post_wakeup,
    s03_cc,
    s04_retrieve,
    s05_registration_forms,
    s06_self_and_multi,
    s07_errors,
    s08_keepalive_callback,
    s09_walkthrough,
)


def render(session: Session) -> str:
    """Return the JSON text of one session file."""
    return json.dumps(session.to_json(), indent=1, ensure_ascii=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="fail if a file is stale")
    args = parser.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    stale = 0
    for build in ALL_SESSIONS:
        session = build()
        path = OUT / f"{session.name}.json"
        text = render(session)
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                print(f"stale: {path.relative_to(ROOT)}", file=sys.stderr)
                stale += 1
        else:
            path.write_text(text, encoding="utf-8")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
