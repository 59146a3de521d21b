"""Shared fixtures of the ontology tests: a headless browser, live servers, a free port.

The browser is Debian's Chromium driven by Selenium (`/usr/bin/chromium`,
`/usr/bin/chromedriver`), headless, without sandbox or GPU, and without network: the docs are
opened from `file://`. When either binary is missing the browser tests are skipped, unless
`OPENAIR_REQUIRE_BROWSER=1` (set by `make test`), which turns the skip into a failure.

The server runs in a background thread (the CLI under test runs its own event loop in the
calling thread) on 127.0.0.1, port 0, without the web monitor.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import pytest
from ontology_helpers import CHROMEDRIVER, CHROMIUM, ServerThread


def _browser_missing() -> str:
    """Return why the browser cannot run here, or "" when it can."""
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append("the selenium package")
    return ", ".join(missing)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One headless Chromium per test module (starting one costs a second or two)."""
    missing = _browser_missing()
    if missing:
        message = f"headless browser not available: missing {missing}"
        if os.environ.get("OPENAIR_REQUIRE_BROWSER") == "1":
            pytest.fail(message + " (OPENAIR_REQUIRE_BROWSER=1; run `make deps-browser`)")
        pytest.skip(message)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for argument in ("--headless", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})  # to see script errors
    driver = webdriver.Chrome(service=Service(executable_path=str(CHROMEDRIVER)), options=options)
    try:
        yield driver
    finally:
        driver.quit()


@pytest.fixture
def server_factory() -> Iterator[Any]:
    """Start servers on demand (`server_factory(**ServerOptions fields)`); stop them after."""
    started: list[ServerThread] = []

    def start(**options: Any) -> ServerThread:
        srv = ServerThread(**options)
        started.append(srv)
        return srv

    yield start
    for srv in started:
        srv.stop()


@pytest.fixture
def unused_port() -> int:
    """Return a port on 127.0.0.1 that nothing listens on (bound, then released)."""
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
    return port
