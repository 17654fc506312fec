#!/usr/bin/env python
"""The README's point editor pictures: a screenshot of the editor page and the points PNG.

    python benchmarks/point_editor_picture.py [OUT_DIR]      (default docs/images)

The reference head's points as an automatic finder might report them: confidences drawn
at random (seeded; most high, a few low), the two upper ear points reported missing.
Writes ``point_editor_points.png`` (:func:`mpeg4fba.render.points.render_points`) and,
with Debian's Chromium and playwright (headless, SwiftShader WebGL, no network), opens
the editor page, moves one point and selects another, and saves ``point_editor.png``.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]
MISSING = {"10.9": "no ear found: the head has no outer ear geometry here",
           "10.10": "no ear found: the head has no outer ear geometry here"}


def example():
    """(face, points, confidences): the reference head less its upper ear points."""
    from mpeg4fba.fba import FeaturePointSet
    from mpeg4fba.models import reference_head

    face = reference_head()
    fp = face.points
    keep = [k for k in fp.ids if k not in MISSING]
    points = FeaturePointSet({k: fp[k] for k in keep},
                             {k: v for k, v in fp.vertices.items() if k in keep})
    rng = np.random.default_rng(18)
    conf = {k: float(np.round(np.clip(1 - rng.gamma(1.2, 0.12), 0.05, 1), 2)) for k in keep}
    conf.update({"2.13": 0.31, "2.14": 0.28, "8.4": 0.55, "10.7": 0.18, "11.4": 0.12})
    return face, points, conf


def main(argv=None) -> int:
    from mpeg4fba.render.point_editor import write_point_editor
    from mpeg4fba.render.points import render_points

    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    face, points, conf = example()
    render_points(face, points, out / "point_editor_points.png", confidences=conf)
    print(f"wrote {out / 'point_editor_points.png'}")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        print("point_editor.png skipped: playwright is not installed")
        return 0
    if not Path(CHROMIUM).exists():
        print(f"point_editor.png skipped: {CHROMIUM} is not installed")
        return 0
    with tempfile.TemporaryDirectory() as d:
        page_path = write_point_editor(Path(d) / "review.html", face, points, confidences=conf,
                                       missing=list(MISSING), reasons=MISSING,
                                       title="head.obj: 82 points found, 2 missing")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(page_path.resolve().as_uri())
            page.wait_for_function("document.body.dataset.ready === '1' || !!document.body.dataset.error",
                                   timeout=60000)
            error = page.evaluate("document.body.dataset.error || ''")
            if error:
                print("the page failed:", error)
                return 1
            skin = face.world_vertices("Skin")
            page.evaluate("p => { __editor.select('2.14'); __editor.moveTo('Skin', p); }",
                          (skin[face.points.vertex("2.14")[1]] + [0.004, 0.006, 0]).tolist())
            page.evaluate("__editor.select('8.4')")
            page.wait_for_timeout(500)
            page.screenshot(path=str(out / "point_editor.png"))
            browser.close()
    print(f"wrote {out / 'point_editor.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
