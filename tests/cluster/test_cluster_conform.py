"""The cluster is one conformant server: `openair conform` passes against every node (#22).

One node after the other: the suite assumes it has the server to itself (WB-004 fills a
whiteboard to maxcount and counts what is left), which runs at once on the shared whiteboards
would break on one server as much as on a cluster. The lifecycle notices of each run still
reach the other nodes' AIRCentral.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from netcluster import ROOT, Cluster

pytestmark = pytest.mark.slow


@pytest.mark.timeout(900)
def test_conform_passes_against_every_node(cluster: Cluster) -> None:
    runs = []
    outputs = []
    for node in cluster.nodes:
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


def _summary(output: str) -> str:
    lines = output.splitlines()
    bad = [line for line in lines if line.startswith(("FAIL", "fail", "error"))]
    return "\n".join(bad[:40] + lines[-3:])
