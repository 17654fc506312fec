#!/usr/bin/env python
"""Learn :data:`mpeg4fba.cloning.convention.CONVENTION_SHIFT` and
:data:`mpeg4fba.cloning.template.TEMPLATE_SHIFT` on training identities.

    python -m benchmarks.calibrate_points [--seeds 101-120] [--rounds 3]

The detector's rules put a point where the geometry marks it (a lid's rim, the lips'
contact groove, the profile's chin); the 68-landmark convention that face trackers and
ICT-FaceKit's annotators follow puts some of them a millimetre or two away, the same
way on every face.  This script measures that habit: on each training identity (a random
mix of ICT's identity modes, :func:`benchmarks.ict.identity`; full mesh and a decimated
copy, as in ``bench_find_points``) it finds the points, takes (landmark point - found
point) in the detector's template frame (eye separations), pools each left/right pair
(the right side mirrored), and prints the component-wise median per point as the table
to paste into ``mpeg4fba/cloning/convention.py`` and ``template.py``.  ``--rounds 2`` runs the detector again
with the first round's shifts and adds the median of what is left (the drop back onto
the skin takes part of each shift).

The training seeds (default 101-120) are not the benchmark's regression draw
(``REGRESSION_SEEDS``, 7301-7320) and not a fresh draw: judge the table there.
Reads ``<shared>/data/ict-facekit`` in place; says so and exits 0 when it is absent.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import ict  # noqa: E402
from benchmarks.bench_find_points import draw_identity  # noqa: E402
from mpeg4fba.cloning import convention, detect, template  # noqa: E402
from mpeg4fba.fba.featurepoints import point_order  # noqa: E402

#: Left (or midline) point of each landmark-defined point's pair.
_LEFT = {b: a for a, b in template.PAIRS}


def _seeds(text: str) -> list:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out.extend(range(int(a), int(b or a) + 1))
    return out


#: Points carried from the template by the registration (no geometric mark): their
#: shifts go to TEMPLATE_SHIFT (moving the template's point), the others' to
#: CONVENTION_SHIFT (moving the found point).
CARRIED = ("4.1", "4.3", "4.5", "2.11")


def residuals(data, seeds, shift: dict, template_shift: dict) -> dict:
    """{left point: [(3,) landmark - found, template frame]} over the training heads,
    the detector run with ``shift`` as its CONVENTION_SHIFT and ``template_shift`` as its
    TEMPLATE_SHIFT."""
    # the tables are read where they live, by the functions that use them
    old = convention.CONVENTION_SHIFT, template.TEMPLATE_SHIFT
    convention.CONVENTION_SHIFT, template.TEMPLATE_SHIFT = shift, template_shift
    template.reference_template.cache_clear()
    template.mirrored_template.cache_clear()
    out: dict = {}
    try:
        for i, seed in enumerate(seeds):
            ident = draw_identity(data, i, seed)
            for face in (ident.full, ident.decimated):
                world = ict.placed_face(face, None, eyes=True, name=face.name)
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        found = detect.find_feature_points(world)
                except detect.FaceNotFoundError as e:
                    print(f"  {face.name}: {e}", flush=True)
                    continue
                s, R, t = found.fit["s"], found.fit["R"], found.fit["t"]
                frame = lambda p: s * np.asarray(p) @ R.T + t      # noqa: E731
                for k, lm in ident.landmarks.items():
                    if k not in found.points:
                        continue
                    d = frame(lm) - frame(found.points[k])
                    if k in _LEFT:
                        k, d = _LEFT[k], d * [-1, 1, 1]
                    out.setdefault(k, []).append(d)
            print(f"  identity {seed} done", flush=True)
    finally:
        convention.CONVENTION_SHIFT, template.TEMPLATE_SHIFT = old
        template.reference_template.cache_clear()
        template.mirrored_template.cache_clear()
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="101-120", help="training identity seeds, e.g. 101-120")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    data = ict.load_or_say()
    if data is None:
        return 0
    seeds = _seeds(args.seeds)
    shift: dict = {}
    carried: dict = {k: (0.0, 0.0, 0.0) for k in CARRIED}
    for r in range(args.rounds):
        print(f"round {r + 1}: {len(seeds)} identities x 2 heads", flush=True)
        res = residuals(data, seeds, shift, carried)
        for k, v in res.items():
            a = np.array(v)
            med = np.median(a, axis=0)
            table = carried if k in CARRIED else shift
            table[k] = tuple(np.round(np.asarray(table.get(k, (0, 0, 0))) + med, 4))
            spread = np.median(np.linalg.norm(a - med, axis=1))
            print(f"    {k:5s} n={len(a):3d} median residual {np.round(med * 100, 2)} % ES, "
                  f"spread about it {spread * 100:.2f} %", flush=True)
    for name, table in (("CONVENTION_SHIFT", shift), ("TEMPLATE_SHIFT", carried)):
        print(f"\n{name}: dict = {{")
        for k in point_order(table):
            x, y, z = table[k]
            print(f'    "{k}": ({x:+.4f}, {y:+.4f}, {z:+.4f}),')
        print("}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
