"""The docs site in real headless Chromium, from file:// and without network.

Generated from the example ontology, psySpec and history; checked through the DOM: the tree
shows Input > Perc > ..., collapses and expands, the search filters it by words and by
patterns, and a type page shows the full dotted name, the matching patterns and who posts and
receives the type. Screenshots go to test-artifacts/ontology/ (kept, not committed).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from ontology_helpers import ARTIFACTS, HISTORY, ONTOLOGY, PSYSPEC

from openair.server.core.config import load_config
from openair_ontology.history import read_xml
from openair_ontology.parse import read_ontology
from openair_ontology.site import build_context, write_site
from openair_ontology.usage import merge, usage_from_config, usage_from_history

SENTENCE = "Input.Perc.UniM.Hear.Voice.Speak.Sentence"
BOUND = 5.0  # seconds any DOM condition may take to hold


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    usage = merge(
        [
            usage_from_config(load_config(PSYSPEC)),
            usage_from_history(read_xml(HISTORY).messages),
        ]
    )
    out = tmp_path_factory.mktemp("browser-site")
    write_site(build_context(read_ontology(ONTOLOGY), usage), out)
    return out


def _node(driver: Any, name: str) -> Any:
    from selenium.webdriver.common.by import By

    return driver.find_element(By.CSS_SELECTOR, f'li.node[data-type="{name}"]')


def _toggle(driver: Any, name: str) -> Any:
    from selenium.webdriver.common.by import By

    return _node(driver, name).find_element(By.CSS_SELECTOR, ":scope > .row > .toggle")


def _until(driver: Any, condition: Callable[[], bool]) -> None:
    from selenium.webdriver.support.ui import WebDriverWait

    WebDriverWait(driver, BOUND).until(lambda _: condition())


def _shown(driver: Any, name: str) -> bool:
    return bool(_node(driver, name).is_displayed())


def _no_script_errors(driver: Any) -> None:
    logs = driver.get_log("browser")
    assert [entry for entry in logs if entry["level"] == "SEVERE"] == []


def test_tree_collapses_and_expands(browser: Any, site: Path) -> None:
    browser.get((site / "index.html").as_uri())
    assert browser.title.startswith("Overview")
    roots = [
        el.get_attribute("data-type")
        for el in browser.find_elements("css selector", "#tree > li.node")
    ]
    assert roots[:3] == ["Input", "Output", "Skundar"]
    # At rest the top level is open and everything deeper is closed: Input > Perc shows.
    assert _shown(browser, "Input.Perc") and not _shown(browser, "Input.Perc.UniM")
    _toggle(browser, "Input.Perc").click()
    _until(browser, lambda: _shown(browser, "Input.Perc.UniM"))
    assert _toggle(browser, "Input.Perc").get_attribute("aria-expanded") == "true"
    _toggle(browser, "Input.Perc").click()
    _until(browser, lambda: not _shown(browser, "Input.Perc.UniM"))
    _toggle(browser, "Input").click()
    _until(browser, lambda: not _shown(browser, "Input.Perc"))
    assert _toggle(browser, "Input").get_attribute("aria-expanded") == "false"
    browser.find_element("id", "expand-all").click()
    _until(browser, lambda: _shown(browser, SENTENCE))
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    browser.save_screenshot(str(ARTIFACTS / "index.png"))
    _no_script_errors(browser)


def test_search_filters_the_tree(browser: Any, site: Path) -> None:
    browser.get((site / "index.html").as_uri())
    search = browser.find_element("id", "search")
    search.send_keys("sentence")
    _until(browser, lambda: _shown(browser, SENTENCE))
    assert "match" in (_node(browser, SENTENCE).get_attribute("class") or "")
    assert _shown(browser, "Input.Perc.UniM.Hear")  # ancestors stay, opened
    assert not _shown(browser, "Skundar") and not _shown(browser, "Input.Perc.UniM.Vis")
    assert browser.find_element("id", "search-status").text == "1 type matches."
    search.clear()
    search.send_keys("*.Track")  # a pattern: OpenAIR matching, not words
    _until(browser, lambda: _shown(browser, "Skundar.Input.Perc.Track"))
    assert not _shown(browser, SENTENCE)
    assert browser.find_element("id", "search-status").text == "1 type matches."
    search.clear()
    search.send_keys("Psyclone.Module.Lost.*")  # a family matches through one member
    _until(browser, lambda: _shown(browser, "Psyclone.Module.Lost"))
    assert not _shown(browser, "Psyclone.Module.Connect")
    from selenium.webdriver.common.keys import Keys

    search.send_keys(Keys.ESCAPE)  # back to the resting tree
    _until(browser, lambda: _shown(browser, "Skundar") and not _shown(browser, SENTENCE))
    _no_script_errors(browser)


def test_type_page_through_the_tree(browser: Any, site: Path) -> None:
    browser.get((site / "index.html").as_uri())
    browser.find_element("id", "search").send_keys("sentence")
    _until(browser, lambda: _shown(browser, SENTENCE))
    _node(browser, SENTENCE).find_element("css selector", ":scope > .row > a").click()
    _until(browser, lambda: browser.title.startswith(SENTENCE))
    assert browser.find_element("id", "fullname").text == SENTENCE
    patterns = browser.find_element("id", "patterns").text
    assert "Input.Perc.UniM.*" in patterns and "Input.Perc.UniM.Hear.Voice.Speak.*" in patterns
    assert "SpeechRecognizer" in browser.find_element("id", "posters").text
    receivers = browser.find_element("id", "subscribers").text
    assert "DialogManager" in receivers and "TurnTaker" in receivers
    # The tree on a type page opens the path to it and marks it.
    assert "current" in (_node(browser, SENTENCE).get_attribute("class") or "")
    assert _shown(browser, SENTENCE) and not _shown(browser, "Input.Perc.UniM.Vis.Face")
    browser.save_screenshot(str(ARTIFACTS / "type-page.png"))
    _no_script_errors(browser)


def test_deprecated_type_links_its_replacement(browser: Any, site: Path) -> None:
    browser.get((site / "types" / "Skundar.Decision.Move2d.html").as_uri())
    banner = browser.find_element("css selector", ".deprecated-banner")
    assert "Deprecated since version 2.0" in banner.text
    banner.find_element("css selector", "a").click()
    _until(browser, lambda: browser.title.startswith("Skundar.Decision.Cmd2dMove"))
    assert browser.find_element("id", "fullname").text == "Skundar.Decision.Cmd2dMove"
