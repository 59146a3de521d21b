"""One headless Chromium for the browser tests (the ontology site and the web monitor).

Debian's Chromium driven by Selenium (`/usr/bin/chromium`, `/usr/bin/chromedriver`): headless,
without sandbox or GPU, without background network. When a binary or Selenium is missing the
browser tests are skipped, unless `OPENAIR_REQUIRE_BROWSER=1` (set by `make test`, which
installs them), which turns the skip into a failure that says what is missing.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from typing import Any

import pytest

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
_ARGUMENTS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--window-size=1400,1000",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-default-apps",
    "--disable-extensions",
    "--disable-sync",
)


def _missing() -> list[str]:
    missing = [p for p in (CHROMIUM, CHROMEDRIVER) if not shutil.which(p)]
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append("the Python package selenium")
    return missing


def headless_chromium() -> Iterator[Any]:
    """Yield a Selenium driver of a headless Chromium (or skip/fail when there is none)."""
    missing = _missing()
    if missing:
        message = "browser tests need " + ", ".join(missing)
        if os.environ.get("OPENAIR_REQUIRE_BROWSER") == "1":
            pytest.fail(message + " (OPENAIR_REQUIRE_BROWSER=1; `make deps-browser` installs them)")
        pytest.skip(message)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in _ARGUMENTS:
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})  # to see script errors
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()
