#!/usr/bin/env python
"""Cloning grids like Figs. 11-13 of Pandzic's *Facial Motion Cloning*, for the README.

    python benchmarks/clone_pictures.py [OUT_DIR]      (default docs/images)

Five faces: the reference head (the only one made with motion), two reference heads of
other proportions and meshes, and two ICT-FaceKit identities (the second with its skin
decimated to a quarter) when ``<shared>/data/ict-facekit`` is there (three faces
otherwise).  As in the paper, the faces without motion first get it by cloning from the
reference head; then every face is cloned onto every other.  Rows are sources, columns
targets, the diagonal the sources themselves.  Written: ``clone_grid_surprise.png``
(expression 6 at full intensity), ``clone_grid_viseme_ih.png`` (viseme 12, "I") and
``clone_grid_faps.png`` (the paper's Fig. 13 FAP values: open_jaw 800, both lip corners
stretched 150, every lip raise/lower FAP -400, the left eyebrow raised 300).
"""
from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from mpeg4fba.cloning import CloneWarning, clone  # noqa: E402
from mpeg4fba.fba.fat import FAT  # noqa: E402
from mpeg4fba.models import reference_head  # noqa: E402
from mpeg4fba.render.grid import clone_all, cloning_grid  # noqa: E402
from mpeg4fba.render.preview import save_png  # noqa: E402

LIP_FAPS = (4, 5, 8, 9, 10, 11, 51, 52, 55, 56, 57, 58)
FIG13 = {3: 800, 53: 150, 54: 150, **{f: -400 for f in LIP_FAPS}, 31: 300, 33: 300, 35: 300}
POSES = {
    "clone_grid_surprise.png": {"expressions": (6, 63, 0, 0, 0, 0)},
    "clone_grid_viseme_ih.png": {"visemes": (12, 0, 63, 0)},
    "clone_grid_faps.png": {"faps": FIG13},
}
#: ICT meshes not drawn: thin layers over the eyes and the insides of the head.
ICT_HIDDEN = ("LeftEyelashes", "RightEyelashes", "LeftEyeOcclusion", "RightEyeOcclusion",
              "LeftEyeBlend", "RightEyeBlend", "LeftLacrimal", "RightLacrimal",
              "LeftEyeSocket", "RightEyeSocket")


def _eye_colours(face) -> None:
    """Iris and pupil on an ICT eyeball, by distance from its pupil point."""
    for mesh, fp in (("LeftEyeball", "3.5"), ("RightEyeball", "3.6")):
        v = face.meshes[mesh].vertices
        d = np.linalg.norm(v - face.points[fp], axis=1)
        c = np.tile([0.95, 0.94, 0.91], (len(v), 1))
        c[d < 0.55] = (0.27, 0.40, 0.52)
        c[d < 0.25] = (0.05, 0.05, 0.06)
        face.colors[mesh] = c


def faces() -> tuple:
    ref = reference_head()
    wide = reference_head(face_width=1.2, jaw=0.85, nose=1.2, eye_spacing=1.12, mouth_width=0.88,
                          resolution=0.7, seed=5)
    narrow = reference_head(face_width=0.85, jaw=1.2, nose=0.9, eye_spacing=0.92, mouth_width=1.15,
                            resolution=1.3, seed=7)
    out, names = [ref, wide, narrow], ["reference", "wide", "narrow"]
    try:
        from benchmarks import ict
        data = ict.load_ict()
    except FileNotFoundError as e:
        print(f"ICT faces left out: {e}")
        data = None
    if data is not None:
        a = ict.ict_face(data, ict.identity(data, 1), name="ICT-1")
        b = ict.ict_face_decimated(data, ict.identity(data, 2), 0.25, name="ICT-2-decimated")
        for f in (a, b):
            _eye_colours(f)
        out += [a, b]
        names += ["ICT 1", "ICT 2 dec."]
    # the faces without motion get it from the reference head first, as in the paper
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloneWarning)
        for k in range(1, len(out)):
            out[k].fat = FAT()
            cloned = clone(ref, out[k])
            cloned.colors = dict(out[k].colors)
            out[k] = cloned
    return out, names


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out_dir = Path(argv[0]) if argv else ROOT / "docs" / "images"
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    models, names = faces()
    grid = clone_all(models)
    print(f"{len(models)} faces cloned onto each other in {time.perf_counter() - t0:.1f} s")
    for filename, pose in POSES.items():
        image = cloning_grid(models, pose, names=names, size=(200, 236), cloned=grid,
                             hide=ICT_HIDDEN)
        path = save_png(out_dir / filename, image)
        print(f"wrote {path} ({image.shape[1]}x{image.shape[0]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
