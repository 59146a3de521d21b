"""Hand-written one-fault variants of the reference server, judged like mutants (issue 15).

`python -m tools.mutation.faults` reads tests/faults/independent.toml, copies the tree (a
pristine copy and one to patch, under build/faults), records the coverage map of the tree
once, and for each fault applies its one source change to the copy, runs the mutation judge
there (the conformance cases that execute the changed lines, on the faulty server started
in-process) and restores the file. It writes test-artifacts/independent-faults.md and exits 1
when a fault without a `gap` note survives, or a `gap` fault is caught (the note is stale).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from tools.mutation.campaign import Campaign, Settings, judge_command

__all__ = ["Fault", "apply", "load_faults", "main"]

ROOT = Path(__file__).resolve().parents[2]
CATALOGUE = ROOT / "tests" / "faults" / "independent.toml"
REPORT = ROOT / "test-artifacts" / "independent-faults.md"


@dataclass(frozen=True, slots=True, kw_only=True)
class Fault:
    """One hand-written fault: a single source change and what it breaks."""

    id: str
    klass: str
    requirements: tuple[str, ...]
    what: str
    file: str
    old: str
    new: str
    gap: str = ""


def load_faults(path: Path = CATALOGUE) -> list[Fault]:
    """Read the catalogue; ValueError for a fault without its fields or a repeated id."""
    raw = tomllib.loads(path.read_text(encoding="utf-8")).get("fault", [])
    faults: list[Fault] = []
    for entry in raw:
        try:
            fault = Fault(
                id=entry["id"],
                klass=entry["class"],
                requirements=tuple(entry["requirements"]),
                what=entry["what"],
                file=entry["file"],
                old=entry["old"],
                new=entry["new"],
                gap=entry.get("gap", ""),
            )
        except KeyError as exc:
            raise ValueError(f"{path}: a fault lacks {exc}") from exc
        if fault.old == fault.new or not fault.requirements:
            raise ValueError(f"{path}: {fault.id}: no change, or no requirement cited")
        faults.append(fault)
    ids = [f.id for f in faults]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{path}: repeated fault ids")
    return faults


def apply(fault: Fault, source: str) -> str:
    """Return `source` with the fault applied; ValueError unless `old` occurs exactly once."""
    count = source.count(fault.old)
    if count != 1:
        raise ValueError(f"{fault.id}: the text to change occurs {count} times in {fault.file}")
    return source.replace(fault.old, fault.new)


def _judge(fault: Fault, campaign: Campaign, copy: Path, timeout: float) -> dict[str, object]:
    target = copy / fault.file
    original = target.read_text(encoding="utf-8")
    target.write_text(apply(fault, original), encoding="utf-8")
    try:
        command = judge_command(copy, campaign.map_path, campaign.pristine, 1.0)
        done = subprocess.run(
            command, shell=True, capture_output=True, text=True, timeout=timeout, check=False
        )
        last = (done.stdout.strip().splitlines() or ["{}"])[-1]
        try:
            record: dict[str, object] = json.loads(last)
        except ValueError:
            record = {"verdict": "killed", "killer": f"crash: {done.stderr.strip()[-200:]}"}
    except subprocess.TimeoutExpired:
        record = {"verdict": "killed", "killer": "timeout"}
    finally:
        target.write_text(original, encoding="utf-8")
    return record


def _report(rows: Sequence[tuple[Fault, dict[str, object]]]) -> str:
    caught = sum(1 for _, r in rows if r.get("verdict") == "killed")
    lines = [
        "# Independent one-fault variants, judged by the suite",
        "",
        "Faults of tests/faults/independent.toml (`make faults`), each applied alone to the "
        "reference server and judged by the conformance cases that execute the changed lines.",
        "",
        f"Caught: {caught} of {len(rows)}.",
        "",
        "| fault | class | requirements | what | verdict | caught by / cases run |",
        "|---|---|---|---|---|---|",
    ]
    for fault, r in rows:
        verdict = "caught" if r.get("verdict") == "killed" else "**missed**"
        how = str(r.get("killer") or f"{r.get('cases', 0)} cases ({r.get('kind', '')})")
        reqs = ", ".join(fault.requirements)
        lines.append(f"| {fault.id} | {fault.klass} | {reqs} | {fault.what} | {verdict} | {how} |")
    gaps = [f"- {f.id}: {f.gap}" for f, r in rows if f.gap and r.get("verdict") != "killed"]
    return "\n".join([*lines, "", "## Known gaps", "", *(gaps or ["(none)"])]) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Judge every fault (or those named); write the report; 0 when the outcome is expected."""
    parser = argparse.ArgumentParser(prog="python -m tools.mutation.faults")
    parser.add_argument("ids", nargs="*", help="fault ids (default: all)")
    parser.add_argument("--cache", type=Path, default=ROOT / "build" / "faults")
    parser.add_argument("--report", type=Path, default=REPORT)
    parser.add_argument("--timeout", type=float, default=300.0)
    args = parser.parse_args(argv)
    faults = [f for f in load_faults() if not args.ids or f.id in args.ids]
    settings = Settings(root=ROOT, cache=args.cache.resolve(), modules=(), workers=1)
    campaign = Campaign(settings)
    campaign.prepare()
    copy = campaign.trees / "worker-0"
    rows: list[tuple[Fault, dict[str, object]]] = []
    for fault in faults:
        record = _judge(fault, campaign, copy, args.timeout)
        rows.append((fault, record))
        print(f"{fault.id} {record.get('verdict')} {record.get('killer', '')}", flush=True)
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(_report(rows), encoding="utf-8")
    unexpected = [f.id for f, r in rows if (r.get("verdict") == "killed") == bool(f.gap)]
    print(f"report: {args.report}; unexpected: {', '.join(unexpected) or 'none'}")
    return 1 if unexpected else 0


if __name__ == "__main__":
    sys.exit(main())
