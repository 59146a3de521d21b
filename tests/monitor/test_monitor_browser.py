"""The monitor in a real browser (headless Chromium): overview, live whiteboard, filter, detail.

A server runs on its own event loop in a thread; modules are driven on that loop. The browser
waits with WebDriverWait conditions for what the page shows; screenshots of every step go to
test-artifacts/monitor/. The tests run in file order and build on each other's posts.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Coroutine, Iterator
from typing import Any, TypeVar

import pytest
from monitor_helpers import ARTIFACTS

from openair.client import Module
from openair.protocol.message import Message
from openair.server.aio.app import Server, ServerOptions, start_server
from openair.server.aio.observed import ObservedView
from openair.server.core.queues import QueueItem
from openair_monitor import Monitor, MonitorOptions, attach

T = TypeVar("T")
WAIT = 15.0  # seconds: the most a page may take to show what a step expects


class LiveServer:
    """A server (monitor attached, posting allowed) on a loop in a background thread."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.server: Server = self.call(self._start())
        self.modules: dict[str, Module] = {}

    def call(self, coro: Coroutine[Any, Any, T]) -> T:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(WAIT)

    async def _start(self) -> Server:
        options = ServerOptions(port=0, monitor=False, monitor_post=True, grace_s=0.5)
        server = await start_server(options)
        fast = MonitorOptions(tick_s=0.05, overview_s=0.2, graph_s=0.2)
        server.monitor = await attach(ObservedView(server), fast)
        return server

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server.port}"

    def module(self, name: str, *patterns: str) -> None:
        async def connect() -> None:
            m = Module(name, port=self.server.port, listen=False)
            await m.connect()
            if patterns:
                await m.subscribe(list(patterns))
            self.modules[name] = m

        self.call(connect())

    def post(self, sender: str, to: str, type_: str, content: str) -> None:
        self.call(self.modules[sender].post(to, type_, content))

    def stop(self) -> None:
        async def stop() -> None:
            for m in self.modules.values():
                await m.close()
            await self.server.stop()

        self.call(stop())
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(WAIT)
        self.loop.close()


@pytest.fixture(scope="module")
def live() -> Iterator[LiveServer]:
    server = LiveServer()
    try:
        yield server
    finally:
        server.stop()


def wait(browser: Any, css: str, text: str | None = None) -> Any:
    """Wait until an element matching `css` (containing `text`, if given) is shown."""
    from selenium.common.exceptions import StaleElementReferenceException, TimeoutException
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    def shown(driver: Any) -> Any:
        for element in driver.find_elements(By.CSS_SELECTOR, css):
            if element.is_displayed() and (text is None or text in element.text):
                return element
        return None

    try:
        # Live pages rebuild their rows: an element found may be replaced before it is read.
        stale = (StaleElementReferenceException,)
        return WebDriverWait(browser, WAIT, ignored_exceptions=stale).until(shown)
    except TimeoutException:
        shot(browser, "failed")  # what the page showed instead
        (ARTIFACTS / "failed.html").write_text(browser.page_source)
        raise AssertionError(f"the page never showed {css!r} with {text!r}") from None


def rows(browser: Any, css: str) -> list[Any]:
    from selenium.webdriver.common.by import By

    return list(browser.find_elements(By.CSS_SELECTOR, css))


def shot(browser: Any, name: str) -> None:
    browser.save_screenshot(str(ARTIFACTS / f"{name}.png"))


def no_page_errors(browser: Any) -> None:
    """Fail on JavaScript errors and Content-Security-Policy violations the page logged."""
    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe


def test_overview_shows_a_module_connecting(browser: Any, live: LiveServer) -> None:
    browser.get(live.url + "/")
    wait(browser, "body[data-loaded=yes]")
    wait(browser, '#whiteboards tbody tr[data-name="WB1"]')
    wait(browser, "#live.on")
    shot(browser, "01-overview")
    assert not rows(browser, '#modules tbody tr[data-name="Watcher"]')
    live.module("Watcher", "Test.*")
    wait(browser, '#modules tbody tr[data-name="Watcher"]', "Test.*")
    shot(browser, "02-overview-module-connected")
    no_page_errors(browser)


def test_a_post_appears_live_in_the_whiteboard_view(browser: Any, live: LiveServer) -> None:
    browser.get(live.url + "/whiteboard?wb=WB1")
    wait(browser, "body[data-loaded=yes]")
    wait(browser, "#live.on")
    live.module("Writer")
    live.post("Writer", "WB1", "Test.Browser.Hello", "hello browser")
    row = wait(browser, '#messages tbody tr[data-type="Test.Browser.Hello"]')
    assert "hello browser" in row.text
    shot(browser, "03-whiteboard-live")
    no_page_errors(browser)


def test_the_filter_keeps_only_matching_types(browser: Any, live: LiveServer) -> None:
    field = wait(browser, "#f-pattern")
    field.clear()
    field.send_keys("Test.Other.*")
    wait(browser, "#f-apply").click()
    wait(browser, "#board-title", "WB1")
    live.post("Writer", "WB1", "Test.Browser.Two", "not for this view")
    live.post("Writer", "WB1", "Test.Other.One", "for this view")
    wait(browser, '#messages tbody tr[data-type="Test.Other.One"]')
    types = {r.get_attribute("data-type") for r in rows(browser, "#messages tbody tr")}
    assert types == {"Test.Other.One"}  # Test.Browser.* rows are gone, Two never came
    assert "pattern=Test.Other.*" in browser.current_url.replace("%2A", "*")
    shot(browser, "04-whiteboard-filtered")
    no_page_errors(browser)


def test_opening_a_message_shows_slots_times_and_wakeups(browser: Any, live: LiveServer) -> None:
    wait(browser, '#messages tbody tr[data-type="Test.Other.One"]').click()
    wait(browser, "#detail-facts", "Test.Other.One")
    wait(browser, '#wakeups tbody tr[data-module="Watcher"]', "Test.*")
    latency = wait(browser, "#detail-latency").text
    assert latency.endswith("ms")
    content = wait(browser, '#slots tr[data-slot="content"]')
    assert "for this view" in content.text
    assert wait(browser, '#slots tr[data-slot="receivedTime"]').text.strip() != "receivedTime"
    shot(browser, "05-message-detail")
    no_page_errors(browser)


def test_the_post_form_posts_through_the_router(browser: Any, live: LiveServer) -> None:
    browser.get(live.url + "/post")
    wait(browser, "body[data-loaded=yes]")
    wait(browser, "#p-type").send_keys("Test.Form.Posted")
    wait(browser, "#p-content").send_keys("from the form")
    wait(browser, "#p-send").click()
    result = wait(browser, "#post-result.ok", "RECEIVE_ACCEPT")
    assert "WB1" in result.text
    shot(browser, "06-post-form")
    monitor = live.server.monitor
    assert isinstance(monitor, Monitor)
    stored = [m.type for m, _ in monitor.tap.ring]
    assert stored[-1] == "Test.Form.Posted"
    no_page_errors(browser)


def test_the_graph_and_module_pages(browser: Any, live: LiveServer) -> None:
    browser.get(live.url + "/graph")
    wait(browser, 'svg#graph g.node[data-id="dst:Watcher"]')
    wait(browser, 'svg#graph path.edge[data-from="src:Writer"]')
    shot(browser, "07-type-graph")
    monitor = live.server.monitor
    assert isinstance(monitor, Monitor)
    if not monitor.latency_hooked:
        # This server's dispatcher reports no single deliveries: feed the histogram what the
        # hook would, so that the page's drawing of it is checked all the same.
        async def feed() -> None:
            now = time.time_ns()
            for us in (80, 150, 150, 700, 3000):
                item = QueueItem(message=Message(type="T"), priority=2, wb_priority=1,
                                 due_ns=now - us * 1000)  # fmt: skip
                monitor.tap.delivered("Watcher", item)
            monitor.latency_hooked = True

        live.call(feed())
    browser.get(live.url + "/module?name=Watcher")
    wait(browser, '#triggers tbody tr[data-pattern="Test.*"]')
    wait(browser, "#wakeups tbody tr", "Test.Other.One")
    wait(browser, "svg#histogram rect")
    wait(browser, "#latency .note", "wakeups; mean")
    shot(browser, "08-module")
    no_page_errors(browser)


def test_an_unknown_whiteboard_is_said_not_replaced(browser: Any, live: LiveServer) -> None:
    browser.get(live.url + "/whiteboard?wb=NoSuch")
    error = wait(browser, "#filter-error", "NoSuch")
    assert "no whiteboard" in error.text.lower()
    wait(browser, "body[data-loaded=missing]")
    assert "WB1" not in wait(browser, "#board-title").text
    assert rows(browser, "#messages tbody tr") == []  # not WB1's messages
    shot(browser, "09-unknown-whiteboard")
    no_page_errors(browser)


def test_an_invalid_pattern_is_shown_and_the_view_stays_usable(
    browser: Any, live: LiveServer
) -> None:
    browser.get(live.url + "/whiteboard?wb=WB1&pattern=Test..Bad")
    wait(browser, "#filter-error", "pattern")
    badge = wait(browser, "#live.off")
    assert badge.text != "connecting"
    assert rows(browser, "#messages tbody tr") == []
    shot(browser, "10-invalid-pattern")
    field = wait(browser, "#f-pattern")
    field.clear()
    field.send_keys("Test.Other.*")
    wait(browser, "#f-apply").click()
    wait(browser, "#live.on")
    wait(browser, '#messages tbody tr[data-type="Test.Other.One"]')
    assert not wait(browser, "#status").text.startswith("invalid")
    assert not browser.find_element("css selector", "#filter-error").is_displayed()
    browser.get_log("browser")  # the refused fetch was logged as a 400: expected here


def test_long_content_stays_within_the_detail_panel(browser: Any, live: LiveServer) -> None:
    long_word = "Unbroken" * 400
    live.post("Writer", "WB1", "Test.Long." + "Segment" * 30, long_word + " " + "x " * 2000)
    browser.get(live.url + "/whiteboard?wb=WB1&pattern=Test.Long.*")
    wait(browser, '#messages tbody tr[data-type^="Test.Long."]').click()
    wait(browser, '#slots tr[data-slot="content"]', "Unbroken")
    shot(browser, "11-long-content")
    outside = browser.execute_script(
        """
        const panel = document.getElementById("detail").getBoundingClientRect();
        return Array.from(document.querySelectorAll("#detail *"))
          .filter((e) => e.getBoundingClientRect().right > panel.right + 1)
          .map((e) => e.tagName + (e.id ? "#" + e.id : ""));
        """
    )
    assert outside == []
    page = browser.execute_script(
        "return [document.documentElement.scrollWidth, document.documentElement.clientWidth];"
    )
    assert page[0] <= page[1]  # the page itself does not scroll sideways
    content = wait(browser, '#slots tr[data-slot="content"] pre')
    assert browser.execute_script("return arguments[0].scrollHeight;", content) > int(
        content.size["height"]
    )  # long content scrolls within its box
    no_page_errors(browser)
