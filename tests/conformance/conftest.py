"""Fixtures for the conformance engine tests: servers in a background thread, a recorder.

`target` is the reference server (`openair.server.aio.app.start_server`) when it is installed, else
`FakeServer` (test_engine_support.py).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from test_engine_support import FakeServer, Recorder, ServerThread


def _reference_factory() -> Any | None:
    try:
        from openair.server.aio.app import ServerOptions, start_server
    except ImportError:
        return None
    return lambda: start_server(ServerOptions(host="127.0.0.1", port=0))


@pytest.fixture(scope="session")
def target() -> Iterator[tuple[str, int]]:
    """The server the suite must pass against: the reference server, else FakeServer."""
    factory = _reference_factory() or (lambda: FakeServer().start())
    thread = ServerThread(factory)
    yield ("127.0.0.1", thread.port)
    thread.stop()


@pytest.fixture(scope="session")
def fake_target() -> Iterator[tuple[str, int]]:
    """FakeServer, always (synthetic cases need only the probe)."""
    thread = ServerThread(lambda: FakeServer().start())
    yield ("127.0.0.1", thread.port)
    thread.stop()


@pytest.fixture
def fake_server_with() -> Iterator[Any]:
    """Start FakeServer(**kwargs) on demand; stopped after the test."""
    threads: list[ServerThread] = []

    def start(**kwargs: Any) -> tuple[str, int]:
        thread = ServerThread(lambda: FakeServer(**kwargs).start())
        threads.append(thread)
        return ("127.0.0.1", thread.port)

    yield start
    for thread in threads:
        thread.stop()


@pytest.fixture
def recorder() -> Recorder:
    return Recorder()
