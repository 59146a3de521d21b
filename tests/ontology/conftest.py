"""Shared fixtures of the ontology tests: a headless browser and a free port.

The browser is Debian's Chromium driven by Selenium (`/usr/bin/chromium`,
`/usr/bin/chromedriver`), headless, without sandbox or GPU, and without network: the docs are
opened from `file://`. When either binary is missing the browser tests are skipped, unless
`OPENAIR_REQUIRE_BROWSER=1` (set by `make test`), which turns the skip into a failure.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from browser_support import headless_chromium


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One headless Chromium per test module (starting one costs a second or two)."""
    yield from headless_chromium()


@pytest.fixture
def unused_port() -> int:
    """Return a port on 127.0.0.1 that nothing listens on (bound, then released)."""
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
    return port
