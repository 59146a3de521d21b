"""The three-node cluster fixture (tests/cluster/netcluster.py), shared by the cluster tests."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from netcluster import Cluster, why_not_available


@pytest.fixture(scope="session")
def cluster() -> Iterator[Cluster]:
    reason = why_not_available()
    if reason is not None:
        if os.environ.get("OPENAIR_REQUIRE_CLUSTER"):  # make test: a missing part is a failure
            pytest.fail(f"the cluster tests cannot run: {reason}")
        pytest.skip(reason)
    built = Cluster()
    try:
        built.start()
        yield built
    finally:
        built.close()
