"""Fixtures for the reporter tests: one real engine run against FakeServer, every reporter fed."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from reporters_support import Artifacts, FakeServer, ServerThread, run_all_reporters


@pytest.fixture(scope="session")
def report_target() -> Iterator[tuple[str, int]]:
    """FakeServer on 127.0.0.1, for the whole session."""
    thread = ServerThread(lambda: FakeServer().start())
    yield ("127.0.0.1", thread.port)
    thread.stop()


@pytest.fixture(scope="session")
def artifacts(
    report_target: tuple[str, int], tmp_path_factory: pytest.TempPathFactory
) -> Artifacts:
    """The synthetic cases run once, with every reporter attached."""
    return run_all_reporters(report_target, tmp_path_factory.mktemp("reports"))
