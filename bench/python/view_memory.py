#!/usr/bin/env python3
"""`radar view`'s page in Debian's chromium (Playwright) for some minutes of updates: how long until the page
holds every component, and the page's JavaScript heap (the browser's own `performance.memory`, precise) and DOM
size sampled every 30 s. Prints one JSON line at the end.

    view_memory.py --url URL --expect N --minutes M
"""
import argparse
import json
import time
from typing import Any, Dict, List

from playwright.sync_api import sync_playwright

ARGS = [
    "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--enable-precise-memory-info",
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
]


def sample(page: Any, began: float) -> Dict[str, Any]:
    m = page.evaluate(
        "() => ({heap: performance.memory.usedJSHeapSize, total: performance.memory.totalJSHeapSize,"
        " dom: document.getElementsByTagName('*').length, seq: window.radarView.seq,"
        " rows: document.querySelectorAll('#timeline tbody tr').length})")
    m["t"] = round(time.monotonic() - began, 1)
    return dict(m)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--expect", type=int, required=True)
    ap.add_argument("--minutes", type=float, required=True)
    a = ap.parse_args()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        began = time.monotonic()
        page.goto(a.url)
        page.wait_for_function(
            "n => window.radarView && window.radarView.components.size >= n"
            " && document.querySelectorAll('[data-component]').length >= n", arg=a.expect, timeout=120_000)
        first = time.monotonic() - began
        samples: List[Dict[str, Any]] = [sample(page, began)]
        end = began + a.minutes * 60
        while time.monotonic() < end:
            time.sleep(min(30.0, max(0.0, end - time.monotonic())))
            samples.append(sample(page, began))
        browser.close()
    print(json.dumps({"first_picture_s": round(first, 3), "minutes": a.minutes, "samples": samples}), flush=True)


if __name__ == "__main__":
    main()
