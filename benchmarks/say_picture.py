#!/usr/bin/env python
"""The README's ``say`` picture: the HTML player speaking a sentence.

    python benchmarks/say_picture.py [OUT_DIR]      (default docs/images)

Runs ``mpeg4fba say "Hello! I am a cloned face." --expression joy -o say.html`` into a
temporary folder, opens the page in Debian's Chromium through playwright (headless,
SwiftShader WebGL, sound allowed, no network), pauses on the widest vowel held at its whole share and saves
``say_player.png``.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

TEXT = "Hello! I am a cloned face."


def main(argv=None) -> int:
    from _browser import CHROMIUM, CHROMIUM_ARGS, browser_missing
    from click.testing import CliRunner

    from mpeg4fba.cli import main as cli
    from mpeg4fba.speech import say

    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    why = browser_missing()
    if why:
        print(f"say_player.png skipped: {why}")
        return 1
    u = say(TEXT, expression="joy")
    v = u.stream.visemes
    whole = (v[:, 2] == 63) & np.isin(v[:, 0], [10, 11, 13])    # a vowel at its whole share
    widest = int(np.argmax(np.where(whole, u.stream.values[:, 2], -1)))
    with tempfile.TemporaryDirectory() as d:
        page_path = Path(d) / "say.html"
        r = CliRunner().invoke(cli, ["say", TEXT, "--expression", "joy", "-o", str(page_path)])
        if r.exit_code:
            print(r.output)
            return 1
        from playwright.sync_api import sync_playwright
        with sync_playwright() as p:
            b = p.chromium.launch(executable_path=CHROMIUM,
                                  args=CHROMIUM_ARGS + ["--autoplay-policy=no-user-gesture-required"])
            page = b.new_page(viewport={"width": 900, "height": 640})
            page.goto(page_path.resolve().as_uri())
            page.wait_for_function('document.body.dataset.ready === "1"', timeout=60_000)
            page.evaluate(f"() => {{ __player.pause(); __player.setTime({widest / u.stream.fps}); }}")
            page.wait_for_timeout(500)
            page.screenshot(path=str(out / "say_player.png"))
            b.close()
    print(f"wrote {out / 'say_player.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
