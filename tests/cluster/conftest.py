"""The three-node cluster fixture (tests/cluster/netcluster.py), shared by the cluster tests."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from netcluster import Cluster, why_not_available


@pytest.fixture(scope="session")
def cluster() -> Iterator[Cluster]:
    reason = why_not_available()
    if reason is not None:
        pytest.skip(reason)
    built = Cluster()
    try:
        built.start()
        yield built
    finally:
        built.close()
