"""Fixtures of the monitor's browser tests: headless Chromium through Selenium.

The browser tests skip when Chromium, its driver or Selenium is missing, unless
OPENAIR_REQUIRE_BROWSER=1 (set by `make test`, which installs them): then they fail and say
what is missing.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from browser_support import headless_chromium
from monitor_helpers import ARTIFACTS


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """A headless Chromium (no sandbox, no GPU, no background network) driven by Selenium."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    yield from headless_chromium()
