"""A campaign: copies, the control, cosmic-ray sessions, the workers, the results.

Layout of the cache folder (default build/mutation, ignored by git):

- `trees/pristine`, `trees/worker-N`: fresh copies of the working tree for this run;
- `maps/<tree hash>.json`: the control's coverage map for that tree (reused while it holds);
- `sessions/<module stem>-<module hash>.sqlite`: one cosmic-ray session per module version,
  created by `cosmic-ray init`; a rerun executes only the mutants without a result (resume),
  and a changed module gets a new session.

cosmic-ray generates the mutants, applies and restores each one (`mutate_and_test`, in the
worker's own copy) and runs the judge as the test command under its timeout (a mutant that
hangs is killed and recorded `timeout`). Its `local` distributor runs one mutant at a time in
the current folder and `http` needs worker servers, so this module distributes: one thread per
worker, each with its own copy; results go into the session from the main thread.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import queue
import shlex
import sqlite3
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cosmic_ray.mutating import (  # type: ignore[import-untyped,import-not-found,unused-ignore]
    mutate_and_test,
    mutate_code,
)
from cosmic_ray.plugins import get_operator  # type: ignore[import-untyped,import-not-found,unused-ignore]
from cosmic_ray.work_db import WorkDB, use_db  # type: ignore[import-untyped,import-not-found,unused-ignore]
from cosmic_ray.work_item import (  # type: ignore[import-untyped,import-not-found,unused-ignore]
    MutationSpec,
    TestOutcome,
    WorkerOutcome,
    WorkResult,
)

from tools.mutation.report import RULE_PREFIX, MutantRecord, record_from
from tools.mutation.rules import IF_SURVIVES, PRE_JUDGE, classify, enclosing_function
from tools.mutation.selection import MutantSite, annotation_spans, in_spans, mutant_keys
from tools.mutation.snapshot import copy_tree, module_hash, tracked_files, tree_hash

__all__ = ["INVALID", "IN_ANNOTATION", "Campaign", "Job", "Settings", "judge_command"]

#: The output of a mutant skipped because it lies in an annotation (never evaluated).
IN_ANNOTATION = "skipped: in an annotation (never evaluated: from __future__ import annotations)"
#: The output of a "mutant" whose code does not compile.
INVALID = "invalid: the mutated module does not compile"

_COSMIC_RAY = Path(sys.executable).parent / "cosmic-ray"
#: The operators that can turn code into code that does not compile (`*` and `**` of a
#: parameter list taken for operators); only their mutants are compiled by the filter, which
#: keeps it fast (applying a mutation parses the whole module).
_MAY_NOT_COMPILE = ("core/ReplaceBinaryOperator_Mul_", "core/ReplaceBinaryOperator_Pow_")


@dataclass(frozen=True, slots=True, kw_only=True)
class Settings:
    """What the driver was asked to do."""

    root: Path
    cache: Path
    modules: tuple[str, ...]
    workers: int = 1
    timeout: float = 300.0
    max_mutants: int | None = None
    timeout_scale: float = 1.0
    #: Judge at most this many mutants of each module, chosen by `seed` (None: all of them).
    sample: int | None = None
    seed: str = "0"
    #: Explanation keys (equivalent.toml): mutants they would explain are judged last, so
    #: that a campaign stopped part-way has spent its time on the others. Never skipped.
    explained: frozenset[str] = frozenset()


@dataclass(frozen=True, slots=True, kw_only=True)
class Job:
    """One pending mutant: its session, cosmic-ray work item and stable key."""

    session: Path
    item: Any  # cosmic_ray.work_item.WorkItem
    key: str


def _env(copy: Path) -> dict[str, str]:
    path = os.pathsep.join(str(copy / p) for p in ("reference", "conformance", "."))
    return {**os.environ, "PYTHONPATH": path, "PYTHONDONTWRITEBYTECODE": "1"}


def judge_command(copy: Path, map_path: Path, pristine: Path, timeout_scale: float) -> str:
    """Return the test command cosmic-ray runs for a mutant in `copy`."""
    path = f"PYTHONPATH={copy / 'reference'}:{copy / 'conformance'}:{copy}"
    judge = [sys.executable, "-m", "tools.mutation.judge", "--map", str(map_path)]
    scale = ["--timeout-scale", f"{timeout_scale:g}"]
    return shlex.join(["env", "-C", str(copy), path, *judge, "--pristine", str(pristine), *scale])


def _sample_order(key: str, seed: str = "") -> str:
    """Order mutants by a hash of the seed and their key: a stable, spread-out sample (a
    simple random sample without replacement for a given seed)."""
    return hashlib.sha1(f"{seed}\0{key}".encode()).hexdigest()


class Campaign:
    """Prepare the copies, the map and the sessions; run the pending mutants."""

    def __init__(self, settings: Settings, log: Callable[[str], None] = print) -> None:
        self.s = settings
        self.log = log
        self.trees = settings.cache / "trees"
        self.pristine = self.trees / "pristine"
        self.files = tracked_files(settings.root)
        self.tree = tree_hash(settings.root, self.files)
        self.prepared = False
        #: Modules whose report comes from the session of an earlier version (records()).
        self.earlier: list[str] = []

    @property
    def map_path(self) -> Path:
        """The coverage map of this tree."""
        return self.s.cache / "maps" / f"{self.tree}.json"

    def source(self, module: str) -> str:
        """Return the module's source as this run sees it (the pristine copy once made)."""
        base = self.pristine if self.prepared else self.s.root
        return (base / module).read_text(encoding="utf-8")

    def prepare(self) -> None:
        """Copy the tree (pristine and one per worker) and make sure the map exists."""
        for name in ["pristine", *(f"worker-{i}" for i in range(self.s.workers))]:
            copy_tree(self.s.root, self.trees / name, self.files)
        self.prepared = True
        self.tree = tree_hash(self.pristine, self.files)  # what was copied, not what is now
        if not self.map_path.exists():
            self.run_control(self.map_path)

    def run_control(self, out: Path, globs: Sequence[str] = ()) -> None:
        """Run the control in the pristine copy (every case, one at a time, under coverage)."""
        every = _all_group_modules()
        argv = [sys.executable, "-m", "tools.mutation.control", "--out", str(out)]
        argv += [f"--case={g}" for g in globs] + every
        self.log(f"control run for tree {self.tree} (all cases, sequential, under coverage)")
        subprocess.run(argv, cwd=self.pristine, env=_env(self.pristine), check=True)

    def session_path(self, module: str) -> Path:
        """Return the session file of the module's current source."""
        stem = Path(module).stem
        return self.s.cache / "sessions" / f"{stem}-{module_hash(self.source(module))}.sqlite"

    def init_session(self, module: str) -> Path:
        """Create the module's session with `cosmic-ray init` unless it exists."""
        path = self.session_path(module)
        if path.exists():
            return path
        path.parent.mkdir(parents=True, exist_ok=True)
        config = path.with_suffix(".toml")
        config.write_text(_config_text(module, self.s.timeout), encoding="utf-8")
        tmp = path.with_suffix(".tmp.sqlite")
        tmp.unlink(missing_ok=True)
        cmd = [str(_COSMIC_RAY), "init", str(config), str(tmp)]
        subprocess.run(cmd, cwd=self.pristine, check=True)
        path.with_suffix(".py").write_text(self.source(module), encoding="utf-8")
        tmp.replace(path)
        return path

    def report_session(self, module: str) -> tuple[Path | None, str, bool]:
        """Return (session, its module source, whether it is the current source's) to report.

        The current source's session when it exists; otherwise the newest session of the
        module whose source was kept beside it (another engineer changed the module since that
        campaign: its results stay reportable, marked as of an earlier version).
        """
        path = self.session_path(module)
        if path.exists():
            return path, self.source(module), True
        olders = sorted(
            (p for p in path.parent.glob(f"{Path(module).stem}-*.sqlite") if ".tmp." not in p.name),
            key=lambda p: p.stat().st_mtime,
        )
        for older in reversed(olders):
            kept = older.with_suffix(".py")
            if kept.exists():
                return older, kept.read_text(encoding="utf-8"), False
        return None, "", False

    def filter_session(self, module: str, session: Path) -> int:
        """Record as skipped, before any run, the mutants that need no judge; return how many.

        Mutants inside annotations are equivalent by construction; mutants that do not compile
        (cosmic-ray replaces the keyword-only marker `*` of a parameter list like a
        multiplication) are not mutants at all; a PRE_JUDGE rule (rules.py) explains others
        without a run. All get a SKIPPED result, as cosmic-ray's own filters (cr-filter-pragma)
        record theirs; one judged before this filter is overwritten.
        """
        source = self.source(module)
        spans = annotation_spans(source)
        with use_db(str(session), WorkDB.Mode.open) as db:
            done = {job for job, r in db.results if r.worker_outcome is WorkerOutcome.SKIPPED}
            todo = [item for item in db.work_items if item.job_id not in done]
            marks: dict[str, list[str]] = {IN_ANNOTATION: [], INVALID: []}
            for item in todo:
                m = item.mutations[0]
                hit = classify(source, tuple(m.start_pos), tuple(m.end_pos))
                if in_spans(spans, m.start_pos, m.end_pos):
                    marks[IN_ANNOTATION].append(item.job_id)
                elif m.operator_name.startswith(_MAY_NOT_COMPILE) and not _compiles(source, m):
                    marks[INVALID].append(item.job_id)
                elif hit is not None and hit.when == PRE_JUDGE:
                    marks.setdefault(RULE_PREFIX + hit.reason, []).append(item.job_id)
            for output, ids in marks.items():
                if ids:
                    result = WorkResult(worker_outcome=WorkerOutcome.SKIPPED, output=output)
                    db.set_multiple_results(ids, result)
        return sum(len(ids) for ids in marks.values())

    def reopen_survivors(self, module: str) -> int:
        """Drop the results of the module's surviving mutants so that this run judges them
        again (after new cases were added); return how many."""
        session = self.session_path(module)
        if not session.exists():
            return 0
        with use_db(str(session), WorkDB.Mode.open) as db:
            survived = [j for j, r in db.results if r.test_outcome is TestOutcome.SURVIVED]
        with contextlib.closing(sqlite3.connect(session)) as con, con:
            con.executemany("DELETE FROM work_results WHERE job_id = ?", [(j,) for j in survived])
        return len(survived)

    def reopen_keys(self, module: str, wanted: set[str]) -> int:
        """Drop the results of the module's mutants whose stable keys are in `wanted` (a case
        was added for them), so that this run judges them again; return how many."""
        session = self.session_path(module)
        if not session.exists():
            return 0
        ids = [job for job, key in self.keys(module).items() if key in wanted]
        with contextlib.closing(sqlite3.connect(session)) as con, con:
            con.executemany("DELETE FROM work_results WHERE job_id = ?", [(j,) for j in ids])
        return len(ids)

    def keys(self, module: str) -> dict[str, str]:
        """Return job id -> stable mutant key for every mutant of the module's session."""
        with use_db(str(self.init_session(module)), WorkDB.Mode.open) as db:
            items = db.work_items
        return mutant_keys((_site(i) for i in items), {module: self.source(module)})

    def records(self, module: str) -> list[MutantRecord]:
        """Return the module's mutants and results (nothing when it has no session yet)."""
        session, source, current = self.report_session(module)
        if session is None:
            return []
        if not current:
            self.earlier.append(f"{module} ({session.stem})")
        with use_db(str(session), WorkDB.Mode.open) as db:
            results = dict(db.results)
            items = db.work_items
        keys = mutant_keys((_site(i) for i in items), {module: source})
        return [
            record_from(
                keys[i.job_id],
                i,
                results.get(i.job_id),
                self.s.timeout,
                rule=_survivor_rule(source, i),
                function=enclosing_function(source, i.mutations[0].start_pos[0]),
            )
            for i in items
        ]

    def pending(self) -> list[Job]:
        """Return the pending mutants of every module, in sample order, at most max_mutants.

        With `sample`, each module (a stratum) contributes only the pending ones among the
        first `sample` of its judgeable mutants (not skipped) in the seed's order, so a rerun
        with the same seed resumes the same sample and a larger `sample` extends it.
        """
        jobs: list[Job] = []
        for module in self.s.modules:
            session = self.init_session(module)
            self.filter_session(module, session)
            keys = self.keys(module)
            with use_db(str(session), WorkDB.Mode.open) as db:
                pending = db.pending_work_items
                skipped = {j for j, r in db.results if r.worker_outcome is WorkerOutcome.SKIPPED}
                items = [i for i in db.work_items if i.job_id not in skipped]
            if self.s.sample is not None:
                items.sort(key=lambda i: _sample_order(keys[i.job_id], self.s.seed))
                chosen = {i.job_id for i in items[: self.s.sample]}
                pending = [i for i in pending if i.job_id in chosen]
            jobs += [Job(session=session, item=i, key=keys[i.job_id]) for i in pending]
        source = {m: self.source(m) for m in self.s.modules}

        def explained(job: Job) -> bool:
            module, line = job.key.split(":", 1)[0], job.item.mutations[0].start_pos[0]
            function = enclosing_function(source[module], line)
            wanted = (job.key, ":".join(job.key.split(":")[:2]), f"{module}:def:{function}")
            return any(k in self.s.explained for k in wanted)

        jobs.sort(key=lambda j: (explained(j), _sample_order(j.key, self.s.seed)))
        return jobs if self.s.max_mutants is None else jobs[: self.s.max_mutants]

    def execute(self, jobs: Sequence[Job]) -> None:
        """Run `jobs` on the workers, recording each result in its session as it arrives."""
        todo: queue.Queue[Job] = queue.Queue()
        for job in jobs:
            todo.put(job)
        done: queue.Queue[tuple[Job, Any, float]] = queue.Queue()
        threads = [
            threading.Thread(target=self._worker, args=(i, todo, done), daemon=True)
            for i in range(min(self.s.workers, len(jobs)))
        ]
        for thread in threads:
            thread.start()
        for n in range(1, len(jobs) + 1):
            job, result, seconds = done.get()
            with use_db(str(job.session), WorkDB.Mode.open) as db:
                db.set_result(job.item.job_id, result)
            self.log(f"[{n}/{len(jobs)}] {job.key} {_outcome(result)} {seconds:.1f} s")
        for thread in threads:
            thread.join()

    def _worker(self, index: int, todo: queue.Queue[Job], done: queue.Queue[Any]) -> None:
        copy = self.trees / f"worker-{index}"
        command = judge_command(copy, self.map_path, self.pristine, self.s.timeout_scale)
        while True:
            try:
                job = todo.get_nowait()
            except queue.Empty:
                return
            started = time.monotonic()
            result = mutate_and_test(list(_in_copy(job.item, copy)), command, self.s.timeout)
            done.put((job, result, time.monotonic() - started))


def _compiles(source: str, mutation: Any) -> bool:
    """Return whether the module with this mutation applied compiles (True: no mutation)."""
    operator = get_operator(mutation.operator_name)(**(mutation.operator_args or {}))
    code = mutate_code(source, operator, mutation.occurrence)
    if code is None:
        return True
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # `x is 0` and the like: valid, and a mutant
        try:
            compile(code, "<mutant>", "exec")
        except SyntaxError:
            return False
    return True


def _survivor_rule(source: str, item: Any) -> str:
    """Return the IF_SURVIVES argument for the item's mutation ("" when no rule applies)."""
    m = item.mutations[0]
    hit = classify(source, tuple(m.start_pos), tuple(m.end_pos))
    return hit.reason if hit is not None and hit.when == IF_SURVIVES else ""


def _all_group_modules() -> list[str]:
    from tools.mutation import MODULE_GROUPS

    return [p for paths in MODULE_GROUPS.values() for p in paths]


def _config_text(module: str, timeout: float) -> str:
    # The test command is the worker's (judge_command); this one is never run.
    return (
        "[cosmic-ray]\n"
        f"module-path = {json.dumps([module])}\n"
        f"timeout = {timeout}\n"
        "excluded-modules = []\n"
        'test-command = "false"\n\n'
        '[cosmic-ray.distributor]\nname = "local"\n'
    )


def _site(item: Any) -> MutantSite:
    m = item.mutations[0]
    return MutantSite(
        job_id=item.job_id,
        module=str(m.module_path),
        line=m.start_pos[0],
        column=m.start_pos[1],
        operator=m.operator_name,
        occurrence=m.occurrence,
    )


def _in_copy(item: Any, copy: Path) -> Iterator[Any]:
    """Return the item's mutations pointed at the worker's copy of the module."""
    for m in item.mutations:
        yield MutationSpec(
            module_path=copy / m.module_path,
            operator_name=m.operator_name,
            occurrence=m.occurrence,
            start_pos=m.start_pos,
            end_pos=m.end_pos,
            operator_args=m.operator_args,
            definition_name=m.definition_name,
        )


def _outcome(result: Any) -> str:
    outcome = result.test_outcome.value if result.test_outcome is not None else "-"
    if result.output == "timeout":
        return "timeout"
    last = (result.output or "").strip().splitlines()[-1:] or [""]
    try:
        record = json.loads(last[0])
    except ValueError:
        return f"{outcome} ({result.worker_outcome.value})"
    return f"{outcome} {record.get('kind', '')} {record.get('killer', '')}".rstrip()
