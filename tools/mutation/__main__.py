"""`python -m tools.mutation`: run (or resume) a campaign and write the report.

Examples:
    python -m tools.mutation                                  # every module, 1 worker
    python -m tools.mutation --modules whiteboard queues --max-mutants 60 --workers 2
    python -m tools.mutation --report-only                    # report what the sessions hold
    python -m tools.mutation --rejudge-survivors              # after new cases: survivors again
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from tools.mutation import resolve_modules
from tools.mutation.campaign import Campaign, Settings
from tools.mutation.report import load_explanations, render

ROOT = Path(__file__).resolve().parents[2]
EXPLANATIONS = Path(__file__).resolve().parent / "equivalent.toml"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m tools.mutation", description=__doc__.split("\n")[0])
    p.add_argument("--modules", nargs="*", default=[], help="groups, file stems or paths")
    p.add_argument("--max-mutants", type=int, default=None, help="judge at most N this run")
    p.add_argument(
        "--sample",
        type=int,
        default=None,
        help="judge a seeded random sample of N mutants per module (default: all of them)",
    )
    p.add_argument("--seed", default="15", help="the sample's seed (kept in the report)")
    p.add_argument("--workers", type=int, default=1, help="parallel judges, one copy each")
    p.add_argument("--timeout", type=float, default=300.0, help="seconds per mutant (killed)")
    p.add_argument("--timeout-scale", type=float, default=1.0, help="the suite's deadlines")
    p.add_argument("--cache", type=Path, default=ROOT / "build" / "mutation")
    p.add_argument("--report", type=Path, default=ROOT / "test-artifacts" / "mutation.md")
    p.add_argument("--explanations", type=Path, default=EXPLANATIONS)
    p.add_argument("--report-only", action="store_true", help="run nothing, write the report")
    p.add_argument(
        "--rejudge",
        action="append",
        default=[],
        metavar="KEY",
        help="judge this mutant again (repeatable; after a case was added for it)",
    )
    p.add_argument("--note", action="append", default=[], help="a line for the report's header")
    p.add_argument(
        "--rejudge-survivors",
        action="store_true",
        help="judge the surviving mutants again (after cases were added)",
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the campaign; return 0 when the report is written."""
    args = _parser().parse_args(argv)
    if args.workers < 1:
        raise SystemExit("--workers must be at least 1")
    explanations = load_explanations(args.explanations)  # fail early on a malformed file
    modules = tuple(resolve_modules(args.modules))
    settings = Settings(
        root=ROOT,
        cache=args.cache.resolve(),
        modules=modules,
        workers=args.workers,
        timeout=args.timeout,
        max_mutants=args.max_mutants,
        timeout_scale=args.timeout_scale,
        sample=args.sample,
        seed=args.seed,
        explained=frozenset(explanations),
    )
    campaign = Campaign(settings)
    started = time.monotonic()
    if not args.report_only:
        if args.rejudge_survivors:
            reopened = sum(campaign.reopen_survivors(m) for m in modules)
            print(f"{reopened} surviving mutants to judge again", flush=True)
        if args.rejudge:
            reopened = sum(campaign.reopen_keys(m, set(args.rejudge)) for m in modules)
            print(f"{reopened} of {len(args.rejudge)} named mutants to judge again", flush=True)
        campaign.prepare()
        jobs = campaign.pending()
        print(f"{len(jobs)} mutants to judge with {args.workers} worker(s)", flush=True)
        campaign.execute(jobs)
    records = [r for m in modules for r in campaign.records(m)]
    ran = (
        f"this run: {time.monotonic() - started:.0f} s with {args.workers} worker(s)"
        if not args.report_only
        else "report written from the sessions"
    )
    header = [
        f"Tree {campaign.tree} ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}); "
        f"cosmic-ray 8 operators; judge = the conformance cases that execute the mutated line "
        f"(coverage control), 4 at a time, timeout scale {args.timeout_scale:g}, "
        f"mutant timeout {args.timeout:g} s; {ran}"
        + (f"; sample {args.sample} per module, seed {args.seed!r}." if args.sample else "."),
    ]
    header += args.note
    if campaign.earlier:
        header.append(
            "Changed since their campaign (results of the earlier version, kept beside its "
            "session): " + ", ".join(campaign.earlier) + "."
        )
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(render(records, explanations, header=header), encoding="utf-8")
    print(f"report: {args.report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
