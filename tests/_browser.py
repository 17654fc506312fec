"""Debian's Chromium through playwright, for the tests of our HTML pages (the player,
the point editor): the browser once per module, every page a test opened closed after
it.  A test module takes both fixtures with ``from _browser import browser, close_pages``;
without Chromium or playwright its browser tests skip with the reason."""
from __future__ import annotations

import os

import pytest

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]


def browser_missing() -> str:
    """Why the browser tests cannot run here ("" when they can)."""
    if not os.access(CHROMIUM, os.X_OK):
        return f"Debian's chromium is not installed ({CHROMIUM}; apt-get install chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the Python package playwright is not installed (pip install playwright)"
    return ""


@pytest.fixture(scope="module")
def browser():
    why = browser_missing()
    if why:
        pytest.skip(why)
    from playwright.sync_api import sync_playwright
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture(autouse=True)
def close_pages(request):
    """Close every page a test opened: an open page keeps drawing (software WebGL), and a
    dozen of them left open slowed the later tests several times over."""
    yield
    if "browser" in request.fixturenames:
        for context in request.getfixturevalue("browser").contexts:
            context.close()
