#!/usr/bin/env python
"""Not a benchmark: the README's picture of feature points found on three different heads.

    python benchmarks/find_points_pictures.py [OUT_DIR]      (default docs/images)

Writes ``found_points.png``: front views of what
:func:`mpeg4fba.cloning.find_feature_points` finds on (1) a random ICT-FaceKit person
(a mix of its identity modes, seed 7301, the full head with eyeballs), (2) another
(seed 7306) decimated to 30 % of its skin's vertices, without eyeballs, stood on +Z,
turned 15 degrees and in metres, and (3) the reference head of other proportions, its
points taken away.  Each head is drawn in the frame the finder found (upright, facing
the viewer), the points coloured by confidence.  ICT-FaceKit is read in place from
``<shared>/data/ict-facekit``; without it the script says so and draws nothing.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

SIZE = (460, 600)


def heads() -> list:
    """(caption, face) of the three heads (module docstring), points stripped."""
    from benchmarks import ict
    from mpeg4fba.fba.face import FaceMesh, FaceModel
    from mpeg4fba.models import reference_head

    data = ict.load_ict()
    one = ict.placed_face(ict.ict_face(data, ict.identity(data, 7301)), None, eyes=True, name="ict-7301")
    dec = ict.placed_face(ict.ict_face_decimated(data, ict.identity(data, 7306), 0.30), None,
                          eyes=False, name="ict-7306")
    a = np.radians(15)
    tilt = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    R = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float) @ tilt      # +Z up, facing +X
    dec = FaceModel([FaceMesh(n, dec.world_vertices(n) @ R.T * 0.01, m.triangles)
                     for n, m in dec.meshes.items()], name="ict-7306")
    ref = reference_head(face_width=1.12, jaw=0.9, nose=1.15, mouth_width=1.05, seed=11)
    ref = FaceModel([m for m in ref.meshes.values()], ref.transforms.values(), name="reference")
    return [("ICT person 7301, full, eyeballs", one),
            ("ICT person 7306, 30 % of the skin, no eyeballs, +Z up, metres", dec),
            ("reference head, other proportions", ref)]


def main(argv=None) -> int:
    from mpeg4fba.render.points import upright
    from mpeg4fba.cloning import find_feature_points
    from mpeg4fba.render.preview import save_png
    from mpeg4fba.render.points import points_image

    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else ROOT / "docs" / "images"
    try:
        cases = heads()
    except FileNotFoundError as e:
        print(f"skipped: {e}")
        return 0
    tiles = []
    for caption, face in cases:
        found = find_feature_points(face)
        pts = found.points.positions_only()
        shown, shown_pts = upright(face, pts, found.up, found.forward)
        tiles.append(points_image(shown, shown_pts, confidences=found.confidence, size=SIZE,
                                  views=("front",)))
        worst = found.lowest()
        print(f"{caption}: {len(pts)} points, lowest confidence {worst[1]:.2f} ({worst[0]})")
    h = max(t.shape[0] for t in tiles)
    image = np.concatenate([np.pad(t, ((0, h - t.shape[0]), (0, 0), (0, 0)), constant_values=255)
                            for t in tiles], axis=1)
    out.mkdir(parents=True, exist_ok=True)
    save_png(out / "found_points.png", image)
    print(f"wrote {out / 'found_points.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
