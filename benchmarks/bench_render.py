#!/usr/bin/env python
"""PNG preview speed: ``render_face`` with the OpenGL backend against matplotlib's.

    python benchmarks/bench_render.py [--size 800] [--reps 5] [--resolution 1]

Also times building the reference head itself (``reference_head()``, goal <= 2 s).

The case: the reference head (``reference_head(resolution=1)``, about 18,700 triangles,
all meshes), neutral, front view, Gouraud shading, rendered to an 800x800 RGB array.
Timed with ``time.perf_counter`` round one ``render_face(..., backend=B)`` call, after
one warm-up call, best of 5 (``benchmarks.timing.best_of``), for B = "gl" and
"matplotlib"; the scene set-up both share (pose, camera, culling, lighting in numpy) is
timed on its own too.  The one-time cost of GL, importing moderngl and making the EGL
context (plus its self-test draw), is timed in fresh interpreters (best of 3), since it
happens once per process.  Where GL is not available the reason is printed and its
columns say so.  A markdown table row for benchmarks/README.md is printed at the end.
"""
from __future__ import annotations

import argparse
import platform
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # benchmark this working tree, not an installed copy

from benchmarks.timing import best_of  # noqa: E402

import numpy as np  # noqa: E402

from mpeg4fba.models import reference_head  # noqa: E402
from mpeg4fba.render import preview  # noqa: E402
from mpeg4fba.render.preview import render_face  # noqa: E402

# Run in a fresh interpreter: prints the seconds of importing moderngl + making the
# context + its self-test, or "unavailable: why".
_CONTEXT_PROBE = """
import sys, time
sys.path.insert(0, {repo!r})
from mpeg4fba.render import gl        # the package itself is not GL's cost
t0 = time.perf_counter()
ok, reason = gl.gl_available()
print(time.perf_counter() - t0 if ok else "unavailable: " + reason)
"""


def context_time(reps: int) -> tuple:
    """``(best seconds, "")`` of GL's one-time set-up, a fresh interpreter each time,
    or ``(None, why not)``."""
    best = None
    for _ in range(reps):
        out = subprocess.run([sys.executable, "-c", _CONTEXT_PROBE.format(repo=str(REPO))],
                             capture_output=True, text=True, timeout=120)
        line = (out.stdout.strip().splitlines() or [out.stderr.strip() or "no output"])[-1]
        try:
            t = float(line)
        except ValueError:
            return None, line
        best = t if best is None else min(best, t)
    return best, ""


def silhouette_iou(a: np.ndarray, b: np.ndarray) -> float:
    """IoU of the two images' non-background pixels (the corner's colour)."""
    ma = np.abs(a.astype(int) - a[0, 0]).sum(axis=2) > 6
    mb = np.abs(b.astype(int) - b[0, 0]).sum(axis=2) > 6
    return float((ma & mb).sum() / (ma | mb).sum())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=800, help="image width and height")
    ap.add_argument("--reps", type=int, default=5, help="timed calls (best of)")
    ap.add_argument("--resolution", type=float, default=1.0, help="reference head resolution")
    args = ap.parse_args(argv)

    import matplotlib
    reference_head(resolution=0.5)  # imports and module-level tables warm
    # each rep builds anew (reference_head keeps the last few heads it built)
    build_s, face = best_of(lambda: (reference_head.cache_clear(),
                                     reference_head(resolution=args.resolution))[1], args.reps)
    n_tri = sum(len(m.triangles) for m in face.meshes.values())
    size = (args.size, args.size)
    print(f"Python {platform.python_version()}, numpy {np.__version__}, matplotlib "
          f"{matplotlib.__version__}, {platform.machine()}")
    print(f"reference head, resolution {args.resolution:g}: {n_tri:,} triangles; "
          f"{size[0]}x{size[1]} pixels; best of {args.reps} after a warm-up")
    print(f"building the reference head (reference_head(resolution={args.resolution:g})): "
          f"{build_s:.3f} s (goal <= 2 s; was a test until 2026-12)")

    ctx_s, why = context_time(3)
    from mpeg4fba.render import gl
    ok, reason = gl.gl_available()
    print(f"GL: {reason}")
    if ctx_s is not None:
        print(f"  one-time set-up (import moderngl, EGL context, self-test; fresh "
              f"interpreter, best of 3): {ctx_s:.3f} s")
    else:
        print(f"  one-time set-up: {why}")

    def scene():
        return preview.build_scene(face, None, 0, size, "front", None, "gouraud",
                                   preview.BACKGROUND, (-0.45, 0.55, 0.70), None, True, ())
    scene_s, sc = best_of(scene, args.reps)
    print(f"shared scene set-up (numpy): {scene_s:.4f} s, {len(sc.polys):,} triangles "
          "drawn after culling")

    times, images = {}, {}
    for backend in ("gl", "matplotlib"):
        if backend == "gl" and not ok:
            print("gl: skipped")
            continue
        t, images[backend] = best_of(lambda: render_face(face, size=size, backend=backend),
                                     args.reps)
        assert preview.last_backend == backend
        times[backend] = t
        print(f"{backend}: {t:.4f} s per image ({1 / t:.1f} images/s)")
    iou = "-"
    if len(images) == 2:
        iou = f"{silhouette_iou(images['gl'], images['matplotlib']):.4f}"
        print(f"speed-up gl / matplotlib: {times['matplotlib'] / times['gl']:.1f}x; "
              f"silhouette IoU: {iou}")

    gl_cell = f"{times['gl']:.4f}" if "gl" in times else "unavailable"
    ratio = f"{times['matplotlib'] / times['gl']:.1f}x" if "gl" in times else "-"
    ctx_cell = f"{ctx_s:.3f}" if ctx_s is not None else "-"
    print()
    print("| Case | Triangles | Pixels | GL (s) | matplotlib (s) | Speed-up | "
          "GL set-up, once (s) | Shared scene (s) | Silhouette IoU |")
    print("|---|---|---|---|---|---|---|---|---|")
    print(f"| reference head r={args.resolution:g}, neutral, front, Gouraud | {n_tri:,} | "
          f"{size[0]}x{size[1]} | {gl_cell} | {times['matplotlib']:.4f} | {ratio} | "
          f"{ctx_cell} | {scene_s:.4f} | {iou} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
