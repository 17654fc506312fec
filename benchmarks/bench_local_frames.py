#!/usr/bin/env python
"""Local-frame expression cloning (Kong et al.) on ICT-FaceKit: quality and speed.

    python benchmarks/bench_local_frames.py [--quick] [--seeds A B]

Reads ``<shared>/data/ict-facekit`` in place (skips with a message when absent).  Two
identities A and B of the ICT head (seeds 1 and 2, :mod:`benchmarks.ict`; 26,719
vertices in 17 meshes, the same mesh) and all 53 ARKit expressions of A cloned onto B:

* **local frames, w-point scaling on** (the paper's method, ``LocalFrameCloner``);
* **local frames, scaling off** (the local displacement re-expressed in B's frames);
* **plain displacement copy** (``B + delta``);
* **motion cloning** (``FacialMotionCloner``, motion copied as is / FAPU-scaled), skin only.

ICT's expressions are identity-independent, so the truth for every method is
``B + delta_E``: the plain copy is exact by construction, and any scaling (the w-point's
or the FAPU's) shows up as error - it is what each method *does* to motion on a face of
other proportions, measured against a data set that says motion should not change.
Errors: mean, p95 and max over the 53 expressions of the vertex error as % of B's
inter-ocular distance, per region of the skin's front (mouth, eyes, brows, rest; see
:func:`benchmarks.ict.skin_regions`).

Speed: ``clone_keys`` of the 53 key shapes onto B (every mesh, 26,719 vertices), best of
5 after a warm-up (best of 1 with ``--quick``), set-up (frames, spaces) timed apart.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks import ict  # noqa: E402
from benchmarks.timing import best_of  # noqa: E402
from mpeg4fba.cloning import FacialMotionCloner, LocalFrameCloner  # noqa: E402

TARGET_SECONDS = 0.5
REGIONS = ("mouth", "eyes", "brows", "rest")


def stats(errors: np.ndarray, regions: dict) -> dict:
    """errors (K, n_skin) in % IOD -> region -> (mean, p95, max) over all K and vertices."""
    return {r: (float(errors[:, idx].mean()), float(np.percentile(errors[:, idx], 95)),
                float(errors[:, idx].max())) for r, idx in regions.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--seeds", type=int, nargs=2, default=(1, 2))
    args = ap.parse_args(argv)
    data = ict.load_or_say()
    if data is None:
        return 0
    a, b = args.seeds
    A = ict.ict_face(data, ict.identity(data, a), name=f"ICT-{a}")
    B = ict.ict_face(data, ict.identity(data, b), name=f"ICT-{b}")
    names = list(data.expressions)
    full = data.expression_deltas(names)                             # (53, n, 3)
    keys = {m: A.meshes[m].vertices[None] + d for m, d in ict.split_deltas(A, full).items()}
    truth = ict.split_deltas(B, full)["Skin"]                        # (53, n_skin, 3)
    n_vertices = sum(len(m.vertices) for m in B.meshes.values())
    iod = float(np.linalg.norm(B.points["3.5"] - B.points["3.6"]))
    regions = ict.skin_regions(B)
    regions["rest"] = np.intersect1d(regions["rest"], B.regions[ict.SKIN_FRONT])
    regions["all"] = np.concatenate([regions[r] for r in REGIONS])
    skin0 = B.meshes["Skin"].vertices

    results = {}
    timings = {}
    for label, scale in (("local frames, w-point scaling", True), ("local frames, no scaling", False)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setup, cloner = best_of(lambda: LocalFrameCloner(A, B, scale=scale), 1 if args.quick else 3)
            run, shapes = best_of(lambda: cloner.clone_keys(keys), 1 if args.quick else 5)
        got = np.stack([s["Skin"] for s in shapes]) - skin0
        results[label] = stats(np.linalg.norm(got - truth, axis=2) / iod * 100, regions)
        timings[label] = (setup, run)
        if scale:
            ratios = {k: np.round(v, 3).tolist() for k, v in cloner.ratio.items()}
    results["plain displacement copy"] = stats(np.zeros(truth.shape[:2]), regions)
    for label, scale in (("motion cloning, motion as is", False), ("motion cloning, FAPU-scaled", True)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fmc = FacialMotionCloner(A, B, scale_motion=scale)
        src = ict.split_deltas(A, full)
        motion = np.zeros((len(fmc.src.vertices), len(names), 3))
        for mesh, (first, n) in fmc.source_skin.items():
            motion[first:first + n] = np.moveaxis(src[mesh], 0, 1)
        out = fmc.map_skin(motion.reshape(len(motion), -1))
        first, n = fmc.target_skin["Skin"]
        got = out[first:first + n].reshape(n, len(names), 3).transpose(1, 0, 2)
        results[label] = stats(np.linalg.norm(got - truth, axis=2) / iod * 100, regions)

    print(f"{A.name} -> {B.name}: {len(names)} expressions, {n_vertices:,} vertices; "
          f"errors in % of B's inter-ocular distance ({iod:.2f} cm), mean / p95 / max")
    print(f"{'method':32s} " + " ".join(f"{r:>20s}" for r in REGIONS + ("all",)))
    for label, row in results.items():
        print(f"{label:32s} " + " ".join(f"{row[r][0]:6.3f}/{row[r][1]:6.3f}/{row[r][2]:6.3f}"
                                         for r in REGIONS + ("all",)))
    print(f"\nw-point ratios (target / source local coordinates of bp4, x y z) per space: {ratios}")
    for label, (setup, run) in timings.items():
        verdict = "meets" if run <= TARGET_SECONDS else "MISSES"
        print(f"speed, {label}: {len(names)} expressions onto {n_vertices:,} vertices in {run:.3f} s "
              f"({verdict} the < {TARGET_SECONDS:g} s target); set-up {setup:.3f} s")
    setup, run = timings["local frames, w-point scaling"]
    print("\nREADME row:")
    print(f"| local-frame cloning, {len(names)} expressions onto a {n_vertices:,}-vertex head "
          f"(`benchmarks/bench_local_frames.py`) | {run:.3f} s (set-up {setup:.2f} s) | < {TARGET_SECONDS:g} s |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
