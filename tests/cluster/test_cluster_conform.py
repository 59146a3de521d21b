"""The cluster is one conformant server: `openair conform` passes against every node (#22).

One node after the other, the whole suite each time: the suite assumes it has the server to
itself (WB-004 fills a whiteboard to maxcount and counts what is left), which runs at once on
the shared whiteboards would break on one server as much as on a cluster. The lifecycle
notices of each run still reach the other nodes' AIRCentral, and every run reads whiteboards
the earlier runs filled on other nodes. The run time against each node as a ratio to the
single-process server is `python -m bench cluster`'s (issue #22 asks for 2x at most), not an
assertion here.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from netcluster import ROOT, Cluster

pytestmark = pytest.mark.slow

_FAILING = ("fail", "error", "unexpected-pass")  # what makes `openair conform` exit 1


@pytest.mark.timeout(900)
def test_conform_passes_against_every_node(cluster: Cluster) -> None:
    failed = []
    for node in cluster.nodes:
        report = cluster.workdir / f"conform-{node.name}.json"
        run = subprocess.run(
            ["ip", "netns", "exec", cluster.client_ns, sys.executable, "-m", "openair.cli",
             "conform", node.target, "--json", str(report)],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT, timeout=800,
            check=False,
        )  # fmt: skip
        summary = json.loads(report.read_text())["summary"]
        bad = {v: n for v, n in summary["counts"].items() if v in _FAILING and n}
        if run.returncode != 0 or bad or summary["counts"]["pass"] == 0:
            failed.append(f"{node.name} (exit {run.returncode}, {bad}):\n{_summary(run.stdout)}")
        assert summary["total"] > 200, f"{node.name}: only {summary['total']} cases ran"
    assert not failed, "\n\n".join(failed)


def _summary(output: str) -> str:
    lines = output.splitlines()
    bad = [line for line in lines if line.startswith(("FAIL", "fail", "error", "inconcl"))]
    return "\n".join(bad[:40] + lines[-3:])
