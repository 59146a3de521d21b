"""Write (or check) the canonical files of the message vectors in spec/vectors/messages.

`manifest.json` and the source `.xml` files are hand-maintained data: the expected fields and
errors are written from the spec and, for captured frames, from the psyclone-wire transcripts
(never from the codec). This tool only derives each valid case's `canonical` file, the bytes
`encode_message` writes for the decoded source, so a deliberate change of the canonical form
is one command:

    .venv/bin/python tools/gen_message_vectors.py          # rewrite the canonical files
    .venv/bin/python tools/gen_message_vectors.py --check  # exit 1 when one would change

Review the diff of the canonical files before committing them: C++ and Java read them too.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from openair.protocol.codec import decode_message, encode_message

VECTORS = Path(__file__).resolve().parent.parent / "spec" / "vectors" / "messages"
FORMAT = "openair-message-vectors/1"


def load_manifest(folder: Path = VECTORS) -> dict[str, Any]:
    """Read the manifest and refuse an unknown format."""
    manifest: dict[str, Any] = json.loads((folder / "manifest.json").read_text("utf-8"))
    if manifest.get("format") != FORMAT:
        raise SystemExit(f"{folder / 'manifest.json'}: format is not {FORMAT}")
    return manifest


def canonical_bytes(case: dict[str, Any], folder: Path = VECTORS) -> bytes:
    """Return what encode_message writes for the decoded source of a valid case."""
    chunks = tuple(bytes.fromhex(h) for h in case.get("chunks", ()))
    return encode_message(decode_message((folder / case["file"]).read_bytes(), chunks))


def main(argv: list[str]) -> int:
    """Rewrite the canonical files, or with --check report those that differ."""
    check = "--check" in argv
    stale: list[str] = []
    for case in load_manifest()["cases"]:
        if "canonical" not in case:
            continue
        path = VECTORS / case["canonical"]
        data = canonical_bytes(case)
        if path.exists() and path.read_bytes() == data:
            continue
        stale.append(case["canonical"])
        if not check:
            path.write_bytes(data)
    verb = "differ" if check else "rewritten"
    print(f"{len(stale)} canonical files {verb}" + "".join(f"\n  {name}" for name in stale))
    return 1 if check and stale else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
