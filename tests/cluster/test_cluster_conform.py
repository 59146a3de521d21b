"""The cluster is one conformant server: `openair conform` passes against every node (#22).

One node after the other: the suite assumes it has the server to itself (WB-004 fills a
whiteboard to maxcount and counts what is left), which runs at once on the shared whiteboards
would break on one server as much as on a cluster. The lifecycle notices of each run still
reach the other nodes' AIRCentral.

The first node gets the whole suite; the other nodes share it out by case family (SESS, WB,
MATCH, …, alternately), so every case runs on the first node and on one other, at the time of
two full runs instead of three.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from netcluster import ROOT, Cluster

from openair_conformance.registry import all_cases

pytestmark = pytest.mark.slow


@pytest.mark.timeout(900)
def test_conform_passes_against_every_node(cluster: Cluster) -> None:
    runs = []
    outputs = []
    shares = _shares(len(cluster.nodes))
    for node, share in zip(cluster.nodes, shares, strict=True):
        run = subprocess.Popen(
            [
                "ip",
                "netns",
                "exec",
                cluster.client_ns,
                sys.executable,
                "-m",
                "openair.cli",
                "conform",
                node.target,
                "--json",
                str(cluster.workdir / f"conform-{node.name}.json"),
                *share,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=ROOT,
        )
        outputs.append(run.communicate(timeout=800)[0])
        runs.append(run)
    failed = [
        f"{node.name} (exit {run.returncode}):\n{_summary(out)}"
        for node, run, out in zip(cluster.nodes, runs, outputs, strict=True)
        if run.returncode != 0
    ]
    assert not failed, "\n\n".join(failed)
    for out in outputs:
        assert " pass " in out and "fail" not in out.split("case(s) in")[-1].split("\n")[0]


def _shares(nodes: int) -> list[list[str]]:
    """`--case` options per node: none (the whole suite) for the first, families for the rest."""
    families = sorted({c.info.id.rsplit("-", 1)[0] for c in all_cases()})
    shares: list[list[str]] = [[] for _ in range(nodes)]
    for n, family in enumerate(families if nodes > 1 else ()):
        shares[1 + n % (nodes - 1)] += ["--case", f"{family}-*"]
    return shares


def _summary(output: str) -> str:
    lines = output.splitlines()
    bad = [line for line in lines if line.startswith(("FAIL", "fail", "error"))]
    return "\n".join(bad[:40] + lines[-3:])
