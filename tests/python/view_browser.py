#!/usr/bin/env python3
"""`radar view` in a real browser: Debian's chromium, driven by Playwright for Python, during the paper's
Listing 1 (the `count_up` example), with every request to anywhere but 127.0.0.1 blocked.

    view_browser.py --url URL --count-up EXE --radar EXE --out DIR

The view must already run (started by the Rust test, with --allow-act) in ROS_DOMAIN_ID. Prints one JSON line
per step ({"step": ..., ...}) and {"ok": true, ...} at the end; any failed check raises (exit code 1). Keeps its
screenshots in DIR.
"""
import argparse
import json
import os
import subprocess
import threading
import time
from typing import Any, Callable, List
from urllib.parse import urlparse

import rclpy
from playwright.sync_api import Page, Request, Route, sync_playwright
from std_msgs.msg import Empty  # type: ignore[import-untyped]

CHROMIUM = "/usr/bin/chromium"
# as the machine's notes say: no sandbox as root, and none of chromium's own calls home
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
]


def say(step: str, **more: Any) -> None:
    print(json.dumps({"step": step, **more}), flush=True)


class Interrupted:
    """An rclpy subscriber of /count_up/interrupted, spinning in its own thread: the oracle for acting."""

    def __init__(self) -> None:
        self.node = rclpy.create_node("view_browser_oracle")
        self.count = 0
        self.lock = threading.Lock()
        self.node.create_subscription(Empty, "/count_up/interrupted", self.on, 10)
        self.stop = False
        self.thread = threading.Thread(target=self.spin, daemon=True)
        self.thread.start()

    def on(self, _: Empty) -> None:
        with self.lock:
            self.count += 1

    def seen(self) -> int:
        with self.lock:
            return self.count

    def spin(self) -> None:
        while not self.stop:
            rclpy.spin_once(self.node, timeout_sec=0.05)


def wait(what: str, check: Callable[[], bool], timeout: float) -> float:
    """Waits until `check()` holds; returns how long it took, raises after `timeout` s."""
    began = time.monotonic()
    while not check():
        if time.monotonic() - began > timeout:
            raise AssertionError(f"{what}: not within {timeout} s")
        time.sleep(0.02)
    return time.monotonic() - began


def state_of(page: Page, name: str) -> str:
    return str(page.evaluate(
        "n => { const g = document.querySelector(`[data-component=\"${n}\"]`);"
        " return g ? g.getAttribute('data-state') : ''; }", name))


def rows(page: Page, component: str, signal: str) -> List[int]:
    """The line numbers of the timeline rows of `component`'s `signal`."""
    return [int(n) for n in page.eval_on_selector_all(
        f'#timeline tbody tr[data-component="{component}"][data-signal="{signal}"]',
        "rs => rs.map(r => r.getAttribute('data-n'))")]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--count-up", required=True)
    ap.add_argument("--radar", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rclpy.init()
    oracle = Interrupted()
    blocked: List[str] = []
    errors: List[str] = []

    def only_loopback(route: Route, request: Request) -> None:
        if urlparse(request.url).hostname == "127.0.0.1":
            route.continue_()
        else:
            blocked.append(request.url)
            route.abort()

    example = None
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 820})
            page.route("**/*", only_loopback)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.goto(a.url)
            page.wait_for_selector("#status.live", timeout=10_000)
            loaded = page.evaluate("window.radarViewLoaded")
            say("page live")

            # Listing 1 starts after the page is up: everything it does is seen live
            example = subprocess.Popen([a.count_up, "--duration", "25"], stdout=subprocess.DEVNULL)
            took = wait("the three components appear",
                        lambda: all(page.query_selector(f'[data-component="/{n}"]')
                                    for n in ("count_up", "start_event", "end_event")), 20.0)
            say("components appeared", seconds=round(took, 3))
            page.wait_for_selector('path[data-kind="once"]', state="attached", timeout=10_000)
            page.wait_for_selector('path[data-until]', state="attached", timeout=10_000)
            say("the once ... until connection is drawn")
            page.click('[data-component="/count_up"]')
            page.wait_for_selector('#timeline tbody tr[data-component="/start_event"][data-signal="triggered"]',
                                   timeout=10_000)
            say("start_event's trigger is on the timeline")

            # the page changes while count_up counts, with no reload
            texts = set()
            wait("count_up runs", lambda: state_of(page, "/count_up") == "running", 10.0)
            page.screenshot(path=os.path.join(a.out, "listing1.png"))
            began = time.monotonic()
            while time.monotonic() - began < 4.0:
                texts.add(page.text_content('[data-component="/count_up"] .state') or '')
                time.sleep(0.05)
            assert len(texts) >= 2, f"count_up's box did not change while it ran: {texts}"
            assert page.evaluate("window.radarViewLoaded") == loaded, "the page was reloaded"
            say("the page changed without a reload", texts=sorted(texts))

            # `radar act interrupt /count_up` shows as interrupted within a bound
            wait("count_up runs again", lambda: state_of(page, "/count_up") == "running", 10.0)
            before = max(rows(page, "/count_up", "interrupted"), default=0)
            act = subprocess.run([a.radar, "act", "interrupt", "/count_up", "--json"],
                                 capture_output=True, text=True, timeout=30)
            assert act.returncode == 0, f"radar act: {act.stderr}"
            took = wait("the page shows radar act's interrupt",
                        lambda: max(rows(page, "/count_up", "interrupted"), default=0) > before, 2.0)
            say("radar act interrupt shown", seconds=round(took, 3))
            page.screenshot(path=os.path.join(a.out, "after_radar_act.png"))

            # acting from the page interrupts the response: an rclpy subscriber of interrupted sees it
            # rclpy has heard the interrupts so far (end_event's at 4 s, radar act's), and nothing more comes
            wait("rclpy hears the earlier interrupts", lambda: oracle.seen() >= 2, 5.0)
            heard = oracle.seen()
            time.sleep(0.5)
            assert oracle.seen() == heard, "interrupts that nobody sent"
            for attempt in range(5):
                wait("count_up runs again", lambda: state_of(page, "/count_up") == "running", 10.0)
                page.click("#act-interrupt")
                try:
                    took = wait("rclpy hears the page's interrupt", lambda: oracle.seen() > heard, 3.0)
                    break
                except AssertionError:
                    # count_up ended its run between the look and the click (an idle response ignores it)
                    say("interrupt came too late, again", attempt=attempt)
            else:
                raise AssertionError("acting from the page never interrupted count_up")
            page.wait_for_selector("#act-result:has-text('interrupt sent')", timeout=5_000)
            say("the page's interrupt reached rclpy", seconds=round(took, 3))
            page.screenshot(path=os.path.join(a.out, "after_page_act.png"))

            # the namespace filter: a namespace with nothing in it shows nothing
            page.fill("#filter", "/nowhere")
            wait("the filter hides everything", lambda: page.query_selector("[data-component]") is None, 3.0)
            page.fill("#filter", "")
            page.wait_for_selector('[data-component="/count_up"]', timeout=3_000)
            say("namespace filter")

            # Listing 1 with interrupts from radar act and the page keeps RADAR's rules: none is shown broken
            # (the view judges a sample once it is a second old: the last ones too, after this wait)
            time.sleep(1.2)
            violations = page.evaluate("window.radarView.violations")
            assert violations == [], f"the view says rules were broken: {violations}"
            assert page.is_hidden("#rules-pane"), "the rules pane shows with nothing broken"
            assert page.query_selector(".node.broken") is None, "a component is marked as breaking a rule"
            say("no rule shown broken")

            assert not blocked, f"the page asked for something outside 127.0.0.1: {blocked}"
            assert not errors, f"the page logged errors: {errors}"
            print(json.dumps({"ok": True}), flush=True)
        finally:
            browser.close()
            if example is not None:
                example.terminate()
                example.wait(timeout=20)
            oracle.stop = True
            oracle.thread.join(timeout=2)
            rclpy.shutdown()


if __name__ == "__main__":
    main()
