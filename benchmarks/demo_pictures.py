#!/usr/bin/env python
"""The README's demo pictures: the demo's preview and a screenshot of its HTML player.

    python benchmarks/demo_pictures.py [OUT_DIR]      (default docs/images)

Runs ``mpeg4fba demo`` into a temporary folder, copies its ``preview.png`` to
``demo_preview.png``, then opens ``player.html`` in Debian's Chromium through playwright
(headless, SwiftShader WebGL, no network), moves the animation to the middle of the
phrase and saves ``player.png``.  Without Chromium or playwright only the preview is
written.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]


def main(argv=None) -> int:
    from click.testing import CliRunner

    from mpeg4fba.cli import main as cli

    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as d:
        r = CliRunner().invoke(cli, ["demo", d])
        if r.exit_code:
            print(r.output, r.stderr if hasattr(r, "stderr") else "")
            return 1
        shutil.copyfile(Path(d) / "preview.png", out / "demo_preview.png")
        print(f"wrote {out / 'demo_preview.png'}")
        try:
            from playwright.sync_api import sync_playwright
        except ImportError:
            print("player.png skipped: playwright is not installed")
            return 0
        if not Path(CHROMIUM).exists():
            print(f"player.png skipped: {CHROMIUM} is not installed")
            return 0
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 960, "height": 640})
            page.goto((Path(d) / "player.html").resolve().as_uri())
            page.wait_for_function("document.body.dataset.ready === '1'", timeout=60000)
            page.evaluate("() => { __player.pause(); __player.setTime(__player.duration * 0.62); }")
            page.wait_for_timeout(500)
            page.screenshot(path=str(out / "player.png"))
            browser.close()
        print(f"wrote {out / 'player.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
