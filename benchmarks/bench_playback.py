#!/usr/bin/env python
"""Playback speed of ``FaceModel.play`` (``mpeg4fba.fba.face``): frames per second.

    python benchmarks/bench_playback.py [--quick] [--frames N] [--profile]

The case (see benchmarks/README.md), generated in code, deterministic:

* a 30,000-vertex face: an ellipsoid head ("Skin", 29,000 vertices, 57,600 triangles)
  under a "Head" Transform and two eyeballs (500 vertices each) under "LeftEye" and
  "RightEye"; feature points on the skin where a face has them (so the FAPU is the
  face's own);
* a FAT covering all 66 low-level FAPs (3-68): each moves the skin vertices around its
  feature point (the nearest 300-3,000, log-uniform), along its axis with a smooth
  falloff, in 2 or 3 intervals (bidirectional FAPs have one below 0); FaceDefTransforms
  turn the eyeballs (23-26), push them (27-28) and turn the head (48-50);
* a 1,000-frame stream with all 66 FAPs in every frame: smooth random curves (sums of
  sines) within their ranges.

Before timing, playback of 32 frames is checked against the FAT evaluated entry by entry
(``FaceDefMesh.displacement``), or the script stops.  Timed: ``face.play(stream)`` then
``vertices(mesh)`` of every mesh and ``transform(name)`` of every Transform:
``time.perf_counter`` around it, one warm-up run, best of 3 (best of 1 with ``--quick``).  The one-time ``face.compile()`` is timed on its own (best of 3, a
fresh compile each).  Memory: the output bytes per frame (the arrays returned) and the
``tracemalloc`` peak of one more run divided by the frames.  Single-threaded: the
script sets OMP_NUM_THREADS / OPENBLAS_NUM_THREADS / MKL_NUM_THREADS to 1 before numpy
is imported.  The time of ``mpeg4fba.testing.assert_fap_compliant`` on the same face and
stream is printed for information (the face's FAT is true to its FAPU, so it passes).
A markdown table row for the README is printed at the end.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"      # single-threaded BLAS: must come before numpy is imported

import argparse  # noqa: E402
import cProfile  # noqa: E402
import gc  # noqa: E402
import io  # noqa: E402
import platform  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Callable  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # benchmark this working tree, not an installed copy

from benchmarks.timing import best_of, profile_top  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform  # noqa: E402
from mpeg4fba.fba.fapu import FAPU  # noqa: E402
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform  # noqa: E402
from mpeg4fba.fba.featurepoints import FeaturePointSet  # noqa: E402
from mpeg4fba.fba.stream import FapStream  # noqa: E402
from mpeg4fba.fba.tables import FAP, LOW_LEVEL  # noqa: E402
from mpeg4fba.testing import assert_fap_compliant  # noqa: E402

TARGET = 1000.0   # frames per second
MB = 1e6
RADII = np.array([75.0, 105.0, 90.0])     # the head ellipsoid, model units (mm): x, y, z

#: Feature points as (x, y) on the front of the head (x = the face's left, y = up);
#: z is put on the ellipsoid.  Ears sit at the sides.
POINTS_XY = {
    "2.1": (0, -70), "2.2": (0, -38), "2.3": (0, -42), "2.4": (18, -40), "2.5": (-18, -40),
    "2.6": (9, -38.5), "2.7": (-9, -38.5), "2.8": (9, -41.5), "2.9": (-9, -41.5),
    "2.10": (0, -58), "3.1": (30, 22), "3.2": (-30, 22), "3.3": (30, 14), "3.4": (-30, 14),
    "3.5": (30, 18), "3.6": (-30, 18), "4.1": (12, 32), "4.2": (-12, 32), "4.3": (28, 36),
    "4.4": (-28, 36), "4.5": (44, 32), "4.6": (-44, 32), "5.1": (40, -20), "5.2": (-40, -20),
    "5.3": (35, -5), "5.4": (-35, -5), "6.1": (0, -44), "6.2": (0, -47), "6.3": (5, -46),
    "6.4": (-5, -46), "7.1": (0, -98), "8.1": (0, -34), "8.2": (0, -47), "8.3": (22, -40),
    "8.4": (-22, -40), "8.5": (11, -35), "8.6": (-11, -35), "8.7": (11, -46), "8.8": (-11, -46),
    "9.1": (10, -15), "9.2": (-10, -15), "9.3": (0, -5), "9.15": (0, -18), "10.1": (72, 15),
    "10.2": (-72, 15), "10.3": (72, 0), "10.4": (-72, 0)}

EYE_CENTRES = {"LeftEye": (30.0, 18.0), "RightEye": (-30.0, 18.0)}


def ellipsoid(rings: int, segments: int, radii) -> tuple:
    """(vertices, triangles) of a UV ellipsoid, poles on y, seam at the back; rings
    exclude the poles, so it is ``rings x segments`` vertices and ``2 (rings - 1) x
    segments`` triangles.

    >>> v, t = ellipsoid(4, 6, (1, 1, 1))
    >>> v.shape, t.shape, bool(np.allclose(np.linalg.norm(v, axis=1), 1))
    ((24, 3), (36, 3), True)
    """
    theta = np.linspace(0, np.pi, rings + 2)[1:-1]                 # from the top
    phi = np.linspace(-np.pi, np.pi, segments, endpoint=False)     # 0 = the front (+z)
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    a, b, c = radii
    v = np.stack([a * np.sin(th) * np.sin(ph), b * np.cos(th), c * np.sin(th) * np.cos(ph)],
                 axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rings - 1), np.arange(segments), indexing="ij")
    p, q = i * segments + j, i * segments + (j + 1) % segments
    r, s = p + segments, q + segments
    tris = np.concatenate([np.stack([p, r, q], -1).reshape(-1, 3),
                           np.stack([q, r, s], -1).reshape(-1, 3)])
    return v, tris


def on_head(x: float, y: float) -> np.ndarray:
    """The point of the head's front surface above (x, y)."""
    a, b, c = RADII
    return np.array([x, y, c * np.sqrt(max(1 - (x / a) ** 2 - (y / b) ** 2, 0.0))])


def _table(fap: int, skin: np.ndarray, tree: cKDTree, centre: np.ndarray, unit: float,
           rng: np.random.Generator) -> FaceDefTable:
    """A region-limited FaceDefMesh for ``fap``: the nearest 300-3,000 skin vertices
    to ``centre`` move along the FAP's axis, ``unit`` per FAP unit at the centre."""
    record = FAP[fap]
    count = min(int(np.exp(rng.uniform(np.log(300), np.log(3000)))), len(skin))
    dist, idx = tree.query(centre, k=count)
    order = np.argsort(idx)                      # files list vertices in index order
    dist, idx = dist[order], idx[order]
    radius = dist.max() * 1.0001
    lo, hi = record.range
    n_int = int(rng.integers(2, 4))
    if lo < 0:                                   # bidirectional: one interval below 0
        borders = [lo, 0.0] + list(np.linspace(0, hi, n_int)[1:])
    else:
        borders = list(np.linspace(0, hi, n_int + 1))
    falloff = []
    for j in range(n_int):                       # each interval its own reach
        r = radius * (1.0 - 0.2 * j)
        falloff.append(np.clip(1 - (dist / r) ** 2, 0, None) ** 2)
    d = np.stack(falloff, axis=1)[:, :, None] * (unit * np.asarray(record.axis))[None, None]
    return FaceDefTable(fap, [FaceDefMesh("Skin", borders, idx, d)])


def benchmark_face(seed: int = 0, rings: int = 145, segments: int = 200,
                   eye: tuple = (20, 25)) -> FaceModel:
    """The face described in the module docstring (30,000 vertices by default).

    >>> face = benchmark_face(rings=30, segments=40, eye=(5, 6))
    >>> sorted(face.meshes), len(face.fat.faps), face.fapu.MNS0 > 0
    (['LeftEyeball', 'RightEyeball', 'Skin'], 66, True)
    """
    rng = np.random.default_rng(seed)
    v, t = ellipsoid(rings, segments, RADII)
    skin = FaceMesh("Skin", v, t, parent="Head")
    tree = cKDTree(v)
    ev, et = ellipsoid(eye[0], eye[1], (12.0, 12.0, 12.0))
    transforms = [FaceTransform("Head")]
    meshes = [skin]
    for name, (x, y) in EYE_CENTRES.items():
        centre = on_head(x, y) - [0, 0, 10.0]
        transforms.append(FaceTransform(name, parent="Head", translation=tuple(centre)))
        meshes.append(FaceMesh(name.replace("Eye", "Eyeball"), ev, et, parent=name))
    # Feature points sit on skin vertices (the nearest to where the face has them).
    pos = {k: v[tree.query(on_head(*xy))[1]] for k, xy in POINTS_XY.items()}
    points = FeaturePointSet(pos)
    fapu = FAPU.from_feature_points(points)
    tables = []
    for fap in LOW_LEVEL:
        record = FAP[fap]
        unit = fapu.unit(fap) if record.fapu != "AU" else 15.0 / abs(record.range[1])
        tables.append(_table(fap, v, tree, pos[record.feature_point], unit, rng))
    for fap, tr, axis in ((23, "LeftEye", (0, 1, 0)), (24, "RightEye", (0, 1, 0)),
                          (25, "LeftEye", (1, 0, 0)), (26, "RightEye", (1, 0, 0)),
                          (48, "Head", (1, 0, 0)), (49, "Head", (0, 1, 0)), (50, "Head", (0, 0, 1))):
        tables[fap - 3].transforms.append(FaceDefTransform(tr, "rotation", rotation=axis + (1e-5,)))
    for fap, tr in ((27, "LeftEye"), (28, "RightEye")):
        tables[fap - 3].transforms.append(
            FaceDefTransform(tr, "translation", translation=(0, 0, fapu.ES)))
    return FaceModel(meshes, transforms, points=points, fapu=fapu, fat=FAT(tables), name="bench")


def benchmark_stream(frames: int, seed: int = 1, fps: float = 25.0) -> FapStream:
    """All 66 low-level FAPs in every frame: smooth curves (three sines each) in range.

    >>> s = benchmark_stream(50)
    >>> len(s), len(s.animated), s.out_of_range()
    (50, 66, [])
    """
    rng = np.random.default_rng(seed)
    faps = np.array(LOW_LEVEL)
    lo = np.array([FAP[f].range[0] for f in faps])
    hi = np.array([FAP[f].range[1] for f in faps])
    t = np.arange(frames)[:, None, None] / fps
    freq = rng.uniform(0.1, 2.0, (1, len(faps), 3))
    phase = rng.uniform(0, 2 * np.pi, (1, len(faps), 3))
    wave = np.sin(2 * np.pi * freq * t + phase).mean(axis=2)       # in [-1, 1]
    amp = rng.uniform(0.2, 0.45, len(faps)) * (hi - lo)
    centre = np.where(lo < 0, 0.0, amp)                            # one-sided FAPs stay >= 0
    values = np.zeros((frames, 68))
    values[:, faps - 1] = np.clip(np.round(centre + amp * wave), lo, hi)
    mask = np.zeros((frames, 68), dtype=bool)
    mask[:, faps - 1] = True
    return FapStream(values, mask, fps, name="bench")


def play_all(face: FaceModel, stream: FapStream) -> tuple:
    """Play and compute every mesh's vertices and every transform: (vertices, transforms)."""
    p = face.play(stream)
    return ({m: p.vertices(m) for m in face.meshes}, {t: p.transform(t) for t in face.transforms})


def output_bytes(result: tuple) -> int:
    verts, trs = result
    return sum(v.nbytes for v in verts.values()) + sum(a.nbytes for t in trs.values()
                                                       for a in t.values())


def check_against_fat(face: FaceModel, stream: FapStream, frames: int = 32) -> None:
    """Stop unless playback (the blocked path: >= 16 frames) equals the FAT evaluated
    entry by entry (``FaceDefMesh.displacement``) on a few frames."""
    part = stream[:frames]
    got = face.play(part).vertices("Skin")
    held = part.held()[0]
    for f in (0, frames // 2, frames - 1):
        want = face.meshes["Skin"].vertices.copy()
        for table in face.fat:
            for m in table.meshes:
                want[m.indices] += m.displacement(held[f, table.fap - 1])
        if not np.allclose(got[f], want, rtol=0, atol=1e-9):
            raise SystemExit(f"frame {f}: playback differs from the FAT by "
                             f"{np.abs(got[f] - want).max():g}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="best of 1 instead of best of 3")
    ap.add_argument("--frames", type=int, default=1000, help="frames in the stream (1000)")
    ap.add_argument("--profile", action="store_true", help="cProfile one playback, top functions")
    args = ap.parse_args(argv)
    reps = 1 if args.quick else 3
    threads = ", ".join(f"{v}={os.environ[v]}" for v in
                        ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"))
    print(f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"{platform.machine()}, {os.cpu_count()} CPUs; single-threaded ({threads}, set by "
          f"this script); best of {reps}", flush=True)
    t0 = time.perf_counter()
    face = benchmark_face()
    stream = benchmark_stream(args.frames)
    n_vert = sum(len(m.vertices) for m in face.meshes.values())
    n_tri = sum(len(m.triangles) for m in face.meshes.values())
    nnz = sum(len(m.indices) * m.n_intervals for t in face.fat for m in t.meshes)
    print(f"face: {n_vert:,} vertices, {n_tri:,} triangles, {len(face.meshes)} meshes, "
          f"{len(face.transforms)} transforms, {len(face.fat.faps)} FAPs in the FAT "
          f"({nnz:,} vertex-intervals); stream: {len(stream):,} frames x "
          f"{len(stream.animated)} FAPs (generated in {time.perf_counter() - t0:.1f} s)", flush=True)

    check_against_fat(face, stream)

    def compile_fresh():
        face.invalidate()
        return face.compile()

    csec, _ = best_of(compile_fresh, reps)
    sec, result = best_of(lambda: play_all(face, stream), reps)
    fps = len(stream) / sec
    per_frame = output_bytes(result) / len(stream)
    del result
    gc.collect()
    tracemalloc.start()
    play_all(face, stream)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    met = fps >= TARGET
    print(f"compile (once): {csec * 1e3:.1f} ms", flush=True)
    print(f"playback: {sec:.4f} s for {len(stream):,} frames = {fps:,.0f} frames/s "
          f"(target >= {TARGET:,.0f}: {'met' if met else 'MISSED'}); output {per_frame / 1e3:.1f} kB "
          f"per frame; tracemalloc peak {peak / MB:.0f} MB = {peak / len(stream) / 1e3:.1f} kB "
          f"per frame ({peak / len(stream) / per_frame:.2f}x the output)", flush=True)
    t0 = time.perf_counter()
    report = assert_fap_compliant(face, stream)
    print(f"assert_fap_compliant (informational): {time.perf_counter() - t0:.2f} s, "
          f"{len(report.checked)} FAPs checked, worst error {max(report.worst.values()):.1e}",
          flush=True)
    if args.profile:
        print(profile_top(lambda: play_all(face, stream)))
    print()
    print("| Case | Frames | Compile (ms) | Playback (s) | Frames/s | Target | Met "
          "| Output per frame | tracemalloc peak per frame |")
    print("|---|---|---|---|---|---|---|---|---|")
    print(f"| {n_vert:,} vertices, {n_tri:,} triangles, 66 FAPs every frame | {len(stream):,} | "
          f"{csec * 1e3:.1f} | {sec:.4f} | {fps:,.0f} | >= {TARGET:,.0f} | "
          f"{'yes' if met else '**no**'} | {per_frame / 1e3:.1f} kB | "
          f"{peak / len(stream) / 1e3:.1f} kB ({peak / len(stream) / per_frame:.2f}x) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
