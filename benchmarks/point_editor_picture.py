#!/usr/bin/env python
"""The README's point editor pictures: a screenshot of the editor page and the points PNG.

    python benchmarks/point_editor_picture.py [OUT_DIR]      (default docs/images)

A reference head of other proportions, its points taken away (no teeth, no tongue),
and the points :func:`mpeg4fba.cloning.find_feature_points` finds on it.  Writes ``point_editor_points.png`` (:func:`mpeg4fba.render.points.render_points`) and,
with Debian's Chromium and playwright (headless, SwiftShader WebGL, no network), opens
the editor page, selects the least confident point, and saves ``point_editor.png``.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]


def example():
    """(face, found): a reference head of other proportions with its points taken away
    (skin, hair and eyes kept; no teeth, no tongue), and what the finder makes of it."""
    from mpeg4fba.cloning import find_feature_points
    from mpeg4fba.fba import FeaturePointSet
    from mpeg4fba.fba.face import FaceModel
    from mpeg4fba.models import reference_head

    head = reference_head(face_width=1.12, jaw=0.9, nose=1.15, mouth_width=1.05, seed=11)
    keep = [m for n, m in head.meshes.items() if n in ("Skin", "Hair", "LeftEyeball", "RightEyeball")]
    face = FaceModel(keep, head.transforms.values(), FeaturePointSet(), name="head")
    return face, find_feature_points(face)


def main(argv=None) -> int:
    from mpeg4fba.render.point_editor import write_point_editor
    from mpeg4fba.render.points import render_points

    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    face, found = example()
    points = found.points.positions_only()
    conf = found.confidence
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
                                       missing=found.missing, reasons=found.reasons,
                                       title=f"head.obj: {len(points)} points found, "
                                             f"{len(found.missing)} missing")
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
            page.evaluate("k => __editor.select(k)", found.lowest()[0])
            page.wait_for_timeout(500)
            page.screenshot(path=str(out / "point_editor.png"))
            browser.close()
    print(f"wrote {out / 'point_editor.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
