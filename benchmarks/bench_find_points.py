#!/usr/bin/env python
"""Automatic feature points on ICT-FaceKit heads as users give them (issue 18, "Measure it").

    python -m benchmarks.bench_find_points [--identities N] [--seed S] [--quick]
                                           [--clone K] [--noise K] [--draws D] [--json PATH]
                                           [--md PATH]

Reads ``<shared>/data/ict-facekit`` in place (``$MPEG4FBA_SHARED`` or ``<repo>/../shared``;
says so and exits 0 when it is absent).  **Changes are judged on fresh draws**
(``--seed S``, any S): the fixed regression draw (:data:`REGRESSION_SEEDS`, the default)
is for comparing runs, and a detector tuned on it says little about the next head.

Heads (:mod:`benchmarks.ict`).  Each identity is a random person: the ICT neutral plus
all 20 identity modes with weights ``w_i ~ N(0, 1)`` i.i.d. (ICT's own prior; about 95 %
of the weights within +-2, the head's width varying by about +-10 %), drawn from its case
seed (:func:`benchmarks.ict.identity`).  Each identity gives four heads: its full mesh
(26,719 vertices, Skin 11,248) and its Skin decimated to a fraction U(0.25, 0.35) of its
vertices (:func:`benchmarks.ict.decimate`; our picked points' vertices are kept, as an
artist keeps a vertex at a lip corner; so are the 68 landmarks'), each with and without the eyeball meshes.  Each
of the four is given its own random placement (:func:`benchmarks.ict.random_placement`:
up +Y or +Z, facing any of the four horizontal axes, tilted up to 20 degrees about a
random axis, scale 0.1, 1 or 10, moved), and goes to the detector as a dumb mesh: no
points, regions, colours or FAT, mesh names kept.

Truth.  The points ICT's 68 landmarks define (:data:`benchmarks.ict.LANDMARK_POINTS`, the
table with its rules) on the identity's full-resolution surface.  Errors are measured in
the head's own frame (the placement undone, scale included) in % of the eye distance
ES0 (|3.5 - 3.6| of the identity's pupils, about 6.5 cm): per point group (2 inner lips,
2 chin (jaw-contour landmarks, view-dependent), 3 eyes, 4 brows, 8 outer lips, 9 nose),
median, p95 and max over all points and heads; per slice (full/decimated, with/without
eyes, up axis, scale).  Points the landmarks do not define are checked for plausibility
only: on a surface (within 2 % ES0; not 7.1, nor the pupils of a head without eyeballs),
on the right side of the mid plane (a left point at x > 0, a midline point within 5 %
ES0 of it), inside the head's bounding box, and left/right symmetric (mirror partners'
distance, against the same for our picked points); their distance to our picked points
(``spec_fixtures/ict/feature_points.json``) is shown for reference, not as truth.  A
head on which the detector raises is counted with its message.

Cloning (as ``benchmarks/bench_clone_ict.py``: the eight expressions, scaling off,
``FacialMotionCloner.map_skin``, error on the ICT face area in % ES0, regions and truth
from the identity).  Source: identity :data:`SOURCE_SEED` (full mesh, our picked points).
Targets: of each of the first ``--clone`` identities (default all), the head with
eyeballs (full and decimated in turn) and the same mesh without eyeballs.  The cloner needs an upright face, so it runs in the head's own frame:
the found points are carried back by the known placement.  Each target is cloned twice:
with its found points put in the source's convention (what ``mpeg4fba clone`` does when
it finds all the target's points: :func:`mpeg4fba.cloning.autopoints.matched_points`,
from the source's given points and the ones the detector finds on it), and with the
landmark points
(:func:`benchmarks.ict.landmark_truth`: the landmark table where it defines a point, our
picked point of the same identity elsewhere) from the source as given; and, for context,
a third time with our picked points; per pair the mean (over expressions of the mean
error) and the max (over expressions of the largest vertex error), and the ratio auto /
landmark.

Noise: the landmark points of the first ``--noise`` targets with eyeballs plus Gaussian noise of
sigma 0.5, 1 and 2 mm per axis (ICT is in cm at life size), each point then projected back
onto the mesh it lies on (7.1, inside the neck, and the pupils of a head without
eyeballs stay where the noise puts them), ``--draws`` draws each, cloned as given and
after ``snap_points`` (its crisp points moved onto the geometry, the inner lips' across
the slit in the source's convention, as ``clone --snap`` does), and once more the clean
landmark points snapped (the "0 mm" row: what snapping alone costs); the ratio of max and
mean to the clean landmark points'.

``--json PATH`` writes every case's figures.  Until ``mpeg4fba.cloning.detect`` exists
the harness runs on a STAND-IN (the landmark points themselves, so every error is 0 and
the cloning ratios are 1: a check of the harness, not of a detector) and says so at the
top of its output.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import subprocess
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import ict  # noqa: E402
from benchmarks.bench_clone_ict import EXPRESSIONS, evaluate  # noqa: E402
from benchmarks.ict_pick_points import MIDLINE, PAIRS  # noqa: E402
from mpeg4fba.cloning import FacialMotionCloner  # noqa: E402
from mpeg4fba.cloning.surface import closest_points  # noqa: E402
from mpeg4fba.fba.featurepoints import FeaturePointSet  # noqa: E402
from benchmarks.find_points_report import (GOALS, GROUPS, LANDMARK_IDS, NOISE_MM,  # noqa: E402,F401
                                           ON_SURFACE, case_name, fmt, point_rows, report_cloning,
                                           report_noise, report_plausibility,
                                           report_points, report_raised, report_time,
                                           snap_options, stats, worst_of)

#: The fixed regression draw: one case seed per identity (identity weights, decimation
#: fraction and the four placements all follow from it).  Chosen once, never tuned.
REGRESSION_SEEDS = (7301, 7302, 7303, 7304, 7305, 7306, 7307, 7308, 7309, 7310,
                    7311, 7312, 7313, 7314, 7315, 7316, 7317, 7318, 7319, 7320)
#: The cloning source identity (as bench_clone_ict's default source).
SOURCE_SEED = 1
#: The four heads of an identity: (mesh, eyeballs kept).
VARIANTS = (("full", True), ("decimated", True), ("full", False), ("decimated", False))
#: Decimation fraction range of the Skin.
FRACTION = (0.25, 0.35)
#: Plausibility: how far off the mid plane a midline point may lie (% ES0; off a surface:
#: find_points_report.ON_SURFACE).
MIDLINE_SLACK = 5.0

# -- the detector (or its stand-in) ---------------------------------------------------------
@dataclass
class Detector:
    name: str
    find: object
    snap: object
    crisp: tuple
    real: bool
    errors: tuple = (Exception,)


@dataclass
class StandInFound:
    """What the stand-in "finds": the given points (no detection at all)."""
    points: FeaturePointSet
    confidence: dict = field(default_factory=dict)
    missing: list = field(default_factory=list)
    reasons: dict = field(default_factory=dict)


def load_detector() -> Detector:
    """``mpeg4fba.cloning.detect`` if it is there, else the STAND-IN."""
    try:
        from mpeg4fba.cloning import detect, snapping
    except ImportError:
        def snap(face, points, ids=(), **_):
            return points, {}
        return Detector("STAND-IN (landmark points given back; mpeg4fba.cloning.detect is "
                        "not there yet)", None, snap, tuple(LANDMARK_IDS), False)
    return Detector("mpeg4fba.cloning.detect.find_feature_points", detect.find_feature_points,
                    snapping.snap_points, tuple(snapping.SNAP_POINTS), True)


# -- cases ----------------------------------------------------------------------------------------
@dataclass
class Identity:
    index: int
    seed: int
    vertices: np.ndarray
    fraction: float
    placements: list
    full: object = None            # truth faces (head frame, picked points, regions)
    decimated: object = None
    landmarks: dict = None         # fp -> (3,) head frame
    given: FeaturePointSet = None  # landmark_truth
    es: float = 0.0


def fresh_seeds(seed: int, n: int) -> list:
    """The case seeds of ``--seed seed`` for ``n`` identities (the first ``k`` of a draw
    do not depend on ``n``)."""
    return [int(s) for s in np.random.default_rng(seed).integers(1, 2**31 - 1, n)]


def draw_identity(data, index: int, seed: int) -> Identity:
    rng = np.random.default_rng([seed, 1])
    fraction = float(rng.uniform(*FRACTION))
    placements = [ict.random_placement(rng) for _ in VARIANTS]
    V = ict.identity(data, seed)
    ident = Identity(index, seed, V, fraction, placements)
    ident.full = ict.ict_face(data, V, name=f"ICT-r{seed}")
    ident.decimated = ict.ict_face_decimated(data, V, fraction, name=f"ICT-r{seed}-dec",
                                             keep_ids=data.landmarks)
    ident.landmarks = ict.landmark_points(data, V)
    ident.given = ict.landmark_truth(data, V)
    p = ident.full.points
    ident.es = float(np.linalg.norm(p["3.5"] - p["3.6"]))
    return ident


def _surface(face, eyes: bool) -> tuple:
    verts, tris, first = [], [], 0
    for name, m in face.meshes.items():
        if not eyes and name in ict.EYEBALLS:
            continue
        verts.append(m.vertices)
        tris.append(m.triangles + first)
        first += len(m.vertices)
    return np.vstack(verts), np.vstack(tris)


#: (source face, what the detector finds on it) once the cloning part needs the found
#: points in the source's convention (set by :func:`main`)
SOURCE_FOUND = None


def run_case(det: Detector, ident: Identity, variant: int) -> tuple:
    """Detect the points of one head; (result dict, found points in the head frame or None)."""
    mesh, eyes = VARIANTS[variant]
    truth = ident.full if mesh == "full" else ident.decimated
    pl = ident.placements[variant]
    world = ict.placed_face(truth, pl, eyes=eyes, name=f"{truth.name}-{'eyes' if eyes else 'noeyes'}")
    res = {"identity": ident.index, "seed": ident.seed, "mesh": mesh, "eyes": eyes,
           "fraction": ident.fraction if mesh == "decimated" else 1.0,
           "vertices": int(sum(len(m.vertices) for m in world.meshes.values())),
           "skin_vertices": int(len(world.meshes["Skin"].vertices)),
           "up": pl.up, "facing": pl.facing, "tilt": pl.tilt, "scale": pl.scale,
           "placement": pl.label}
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if det.real:
                found = det.find(world)
            else:
                given = FeaturePointSet({k: pl.apply(ident.given[k]) for k in ident.given})
                found = StandInFound(given, {k: 1.0 for k in given})
    except Exception as e:                                       # noqa: BLE001 (counted)
        res["time"] = time.perf_counter() - t0
        res["cpu"] = time.process_time() - c0
        res["raised"] = f"{type(e).__name__}: {e}"
        return res, None
    res["time"] = time.perf_counter() - t0
    res["cpu"] = time.process_time() - c0
    res["warnings"] = sorted({str(w.message) for w in caught})
    conf = dict(getattr(found, "confidence", {}) or {})
    res["missing"] = list(getattr(found, "missing", []) or [])
    res["reasons"] = {str(k): str(v) for k, v in (getattr(found, "reasons", {}) or {}).items()}
    if conf:
        k = min(conf, key=conf.get)
        res["lowest_confidence"] = (k, float(conf[k]))
    P = found.points
    if SOURCE_FOUND is not None and det.real:
        from mpeg4fba.cloning.autopoints import matched_points
        src, src_found = SOURCE_FOUND
        matched = matched_points(world, found, src, source_found=src_found)
        res["matched"] = {k: [round(float(x), 6) for x in pl.undo(matched[k])] for k in matched}
        # (the vertices they are tied to, as `clone` has them: the cloner holds a point's
        # vertex and gives it its motion unfiltered)
        res["matched_ties"] = {k: [m, int(v)] for k, (m, v) in matched.vertices.items()}
    head = FeaturePointSet({k: pl.undo(P[k]) for k in P}, P.vertices)
    res["found"] = list(head)
    # against the landmark truth
    err, vec = {}, {}
    for fp in LANDMARK_IDS:
        if fp in head:
            d = (head[fp] - ident.landmarks[fp]) / ident.es * 100
            err[fp] = float(np.linalg.norm(d))
            vec[fp] = [round(float(x), 3) for x in d]
    res["errors"] = err
    res["error_vectors"] = vec          # found - truth, head frame (x left, y up, z forward), % ES0
    res["landmark_missing"] = [fp for fp in LANDMARK_IDS if fp not in head]
    res["plausibility"] = plausibility(ident, truth, head, eyes)
    return res, head


def plausibility(ident: Identity, truth, head: FeaturePointSet, eyes: bool) -> dict:
    """Checks of the found points the landmarks do not define (see the module docstring)."""
    others = [k for k in head if k not in ict.LANDMARK_POINTS]
    V, T = _surface(truth, eyes)
    lo, hi = V.min(axis=0), V.max(axis=0)
    margin = 0.01 * (hi - lo)
    picked = ident.full.points
    out = {}
    if others:
        P = np.array([head[k] for k in others])
        dist = closest_points(P, V, T, k=16)[2] / ident.es * 100
    for i, k in enumerate(others):
        p = head[k]
        row = {"surface": float(dist[i])}
        floating = k in ("7.1", "11.5") or (k in ("3.5", "3.6") and not eyes)
        row["on_surface"] = bool(floating or dist[i] <= ON_SURFACE)
        row["in_box"] = bool(k == "11.5" or (np.all(p >= lo - margin) & np.all(p <= hi + margin)))
        if k in picked:
            ref = picked[k]
            row["vs_picked"] = float(np.linalg.norm(p - ref) / ident.es * 100)
            row["x"] = float(p[0] / ident.es * 100)
            if k in MIDLINE or abs(ref[0]) < 0.01 * ident.es:
                row["side_ok"] = bool(abs(p[0]) <= MIDLINE_SLACK / 100 * ident.es)
            else:
                row["side_ok"] = bool(np.sign(p[0]) == np.sign(ref[0]))
        out[k] = row
    sym = {}
    for a, b in PAIRS:
        if a in head and b in head and a in picked and b in picked:
            mirror = np.array([-1.0, 1, 1])
            sym[f"{a}/{b}"] = (float(np.linalg.norm(head[a] - head[b] * mirror) / ident.es * 100),
                               float(np.linalg.norm(picked[a] - picked[b] * mirror) / ident.es * 100))
    return {"points": out, "symmetry": sym}


# -- cloning ------------------------------------------------------------------------------------
def clone_error(data, source, truth, points: FeaturePointSet, eyes: bool) -> dict:
    """Clone the expressions onto ``truth``'s meshes with ``points`` (head frame); mean and
    max % ES0 over the eight expressions, or the exception's message."""
    target = ict.placed_face(truth, None, eyes=eyes, points=points, name=truth.name)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cloner = FacialMotionCloner(source, target, scale_motion=False)
    except Exception as e:                                       # noqa: BLE001 (counted)
        return {"raised": f"{type(e).__name__}: {e}", "time": time.perf_counter() - t0}
    rows = evaluate(cloner, source, truth, list(EXPRESSIONS), data)
    return {"mean": float(np.mean([r["all"][0] for r in rows.values()])),
            "max": float(max(r["all"][2] for r in rows.values())),
            "worst_expression": max(rows, key=lambda n: rows[n]["all"][2]),
            "time": time.perf_counter() - t0}


def noisy(points: FeaturePointSet, truth, eyes: bool, sigma_cm: float,
          rng: np.random.Generator) -> FeaturePointSet:
    """``points`` plus N(0, sigma) per axis, each projected back onto the mesh it lay on."""
    meshes = {n: m for n, m in truth.meshes.items() if eyes or n not in ict.EYEBALLS}
    out = {}
    for k in points:
        p = points[k]
        q = p + rng.normal(0.0, sigma_cm, 3)
        best = None
        for n, m in meshes.items():
            t, b, d = closest_points(p[None], m.vertices, m.triangles, k=8)
            if best is None or d[0] < best[1]:
                best = (n, d[0])
        if k == "7.1" or (k in ("3.5", "3.6") and not eyes):
            out[k] = q                                  # floats: inside the neck, no eyeball
            continue
        m = meshes[best[0]]
        t, b, _ = closest_points(q[None], m.vertices, m.triangles, k=16)
        out[k] = b[0] @ m.vertices[m.triangles[t[0]]]
    return FeaturePointSet(out)


# -- tables -------------------------------------------------------------------------------------
class _Tee:
    """Writes to ``stream`` and keeps a copy (``text``)."""

    def __init__(self, stream):
        self.stream, self.parts = stream, []

    def write(self, s):
        self.parts.append(s)
        return self.stream.write(s)

    def flush(self):
        self.stream.flush()

    @property
    def text(self) -> str:
        return "".join(self.parts)


def write_result(path: Path, text: str) -> None:
    """``text`` written to ``path`` (its folder made) atomically, and said."""
    from mpeg4fba._atomic import atomic_write
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, text)
    print(f"wrote {path}")


def git_commit() -> str:
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    except Exception:                                            # noqa: BLE001
        return "?"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--identities", type=int, default=None,
                    help=f"how many identities (default {len(REGRESSION_SEEDS)}; --quick 3)")
    ap.add_argument("--seed", type=int, default=None,
                    help="a fresh draw from this seed (default: the fixed regression draw)")
    ap.add_argument("--quick", action="store_true", help="3 identities, 2 clonings, no noise")
    ap.add_argument("--clone", type=int, default=None,
                    help="clone onto one head of each of the first K identities (default all)")
    ap.add_argument("--noise", type=int, default=None,
                    help="noise clonings on the first K of those (default 8; --quick 0)")
    ap.add_argument("--draws", type=int, default=2, help="noise draws per level and target")
    ap.add_argument("--json", type=Path, default=None, help="write all results here")
    ap.add_argument("--md", type=Path, default=None,
                    help="write the tables (and the per-head lines) as a markdown page here")
    args = ap.parse_args(argv)
    data = ict.load_or_say()
    if data is None:
        return 0
    n = args.identities or (3 if args.quick else len(REGRESSION_SEEDS))
    if args.seed is None:
        if n > len(REGRESSION_SEEDS):
            ap.error(f"the regression draw has {len(REGRESSION_SEEDS)} identities; give --seed")
        seeds = list(REGRESSION_SEEDS[:n])
        draw = "the fixed regression draw (REGRESSION_SEEDS)"
    else:
        seeds = fresh_seeds(args.seed, n)
        draw = f"a fresh draw, --seed {args.seed}"
    n_clone = min(n, args.clone if args.clone is not None else (2 if args.quick else n))
    n_noise = min(n_clone, args.noise if args.noise is not None else (0 if args.quick else 8))
    det = load_detector()
    t_start = time.perf_counter()
    progress = _Tee(sys.stdout)
    stack = contextlib.ExitStack()
    stack.enter_context(contextlib.redirect_stdout(progress))
    print(f"# find_feature_points on ICT-FaceKit: {n} identities x {len(VARIANTS)} heads, {draw}")
    print(f"detector: {det.name}")
    print(f"command: python -m benchmarks.bench_find_points {' '.join(argv if argv is not None else sys.argv[1:])}")
    print(f"commit {git_commit()}, python {platform.python_version()}, case seeds {seeds}")

    source = ict.ict_face(data, ict.identity(data, SOURCE_SEED), name=f"ICT-{SOURCE_SEED}")
    # what `mpeg4fba clone` does when it finds all the target's points: puts them in the
    # source's convention (cloning.autopoints.matched_points), from what the detector
    # finds on the source
    global SOURCE_FOUND
    if det.real and n_clone:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            SOURCE_FOUND = (source, det.find(ict.placed_face(source, None, name=source.name)))
    if det.real:                   # warm-up, untimed: the first call builds the template
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                det.find(ict.placed_face(source, None, name="warm-up"))
        except Exception as e:                                   # noqa: BLE001
            print(f"warm-up on {source.name} raised {type(e).__name__}: {e}")
        print(f"warm-up call (template built): {time.perf_counter() - t0:.2f} s; "
              f"load average {os.getloadavg()[0]:.1f}")
    cases, pairs, noise_rows = [], [], []
    for i, seed in enumerate(seeds):
        ident = draw_identity(data, i, seed)
        heads = {}
        for v in range(len(VARIANTS)):
            res, head = run_case(det, ident, v)
            cases.append(res)
            heads[v] = head
            errs = res.get("errors", {})
            worst = max(errs, key=errs.get) if errs else None
            print(f"  {case_name(res)}: " + (f"raised {res['raised'][:120]}" if "raised" in res else
                  f"{len(res['found'])} points in {res['time']:.2f} s, landmark median "
                  f"{np.median(list(errs.values())):.2f} max {errs[worst]:.2f} ({worst}) % ES0"),
                  flush=True)
        if i < n_clone:
            # the head with eyeballs, full and decimated in turn; then the same mesh without
            for v in (i % 2, i % 2 + 2):
                mesh, eyes = VARIANTS[v]
                truth = ident.full if mesh == "full" else ident.decimated
                case = cases[-len(VARIANTS) + v]
                name = case_name(case)
                clean = clone_error(data, source, truth, ident.given, eyes)
                if heads[v] is None:
                    auto = {"raised": "detection raised: " + case["raised"]}
                else:
                    use = heads[v]
                    if "matched" in case:
                        use = FeaturePointSet({k: np.asarray(x) for k, x in case["matched"].items()},
                                              {k: tuple(t) for k, t in case["matched_ties"].items()})
                    auto = clone_error(data, source, truth, use, eyes)
                # the landmark points where the landmarks define one, the found (matched)
                # points elsewhere: no detector has the rest on the source's own vertices
                mixed = {}
                if "matched" in case:
                    keep = [k for k in case["matched"] if k not in ict.LANDMARK_POINTS]
                    mix = FeaturePointSet(
                        {**{k: np.asarray(case["matched"][k]) for k in keep},
                         **{k: ident.given[k] for k in ident.given if k in ict.LANDMARK_POINTS}},
                        {k: tuple(case["matched_ties"][k]) for k in keep
                         if k in case["matched_ties"]})
                    mixed = clone_error(data, source, truth, mix, eyes)
                picked = clone_error(data, source, truth, truth.points, eyes) if eyes else {}
                pairs.append({"name": name, "eyes": eyes, "auto": auto, "landmark": clean,
                              "picked": picked, "landmark_found_rest": mixed})
                print(f"    cloned: auto {auto.get('mean', float('nan')):.3f}/{auto.get('max', float('nan')):.2f}, "
                      f"landmark {clean.get('mean', float('nan')):.3f}/{clean.get('max', float('nan')):.2f}"
                      + (f" RAISED {auto.get('raised', '')}{clean.get('raised', '')}"[:200]
                         if 'raised' in auto or 'raised' in clean else ""), flush=True)
            v = i % 2
            mesh, eyes = VARIANTS[v]
            truth = ident.full if mesh == "full" else ident.decimated
            name = case_name(cases[-len(VARIANTS) + v])
            clean = pairs[-2]["landmark"]
            if i < n_noise and "max" in clean:
                rng = np.random.default_rng([ident.seed, 2])
                # the target as `clone --snap` sees it, its points found once for every draw
                target = ict.placed_face(truth, None, eyes=eyes, name=truth.name)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    found = det.find(target) if det.real else None
                src, src_found = SOURCE_FOUND or (None, None)
                # 0 mm: the clean points snapped, what snapping alone costs (no draw taken
                # from rng, so the noisy draws are those of earlier runs)
                for mm in (0.0,) + NOISE_MM:
                    for d in range(args.draws if mm else 1):
                        pts = noisy(ident.given, truth, eyes, mm / 10.0, rng) if mm else ident.given
                        for snap in snap_options(mm):
                            use = pts
                            if snap:
                                # as `clone --snap` does: in the source's convention
                                use, _ = det.snap(target, pts, ids=det.crisp, found=found,
                                                  source=src, source_found=src_found)
                            r = clone_error(data, source, truth, use, eyes)
                            r.update({"mm": mm, "snap": snap, "draw": d, "name": name,
                                      "clean_mean": clean["mean"], "clean_max": clean["max"]})
                            noise_rows.append(r)
                print("    noise: " + ", ".join(
                    f"{x['mm']:g}{'s' if x['snap'] else ''} {x.get('max', float('nan')):.2f}"
                    for x in noise_rows if x["name"] == name), flush=True)

    stack.close()
    wall = time.perf_counter() - t_start
    tables = _Tee(sys.stdout)
    with contextlib.redirect_stdout(tables):
        summary = {"points": report_points(cases), "plausibility": report_plausibility(cases),
                   "raised": report_raised(cases), "time": report_time(cases)}
        if pairs:
            summary["cloning"] = report_cloning(pairs, SOURCE_SEED)
        if noise_rows:
            summary["noise"] = report_noise(noise_rows)
        print(f"\nwall time {wall / 60:.1f} min ({n} identities, {len(cases)} heads, {len(pairs)} "
              f"cloning pairs, {len(noise_rows)} noise clonings); detector: {det.name}")
    if args.md:
        head = progress.text.splitlines()
        page = ["# Automatic feature points on ICT-FaceKit heads (bench_find_points)", "",
                "Written by `python -m benchmarks.bench_find_points` (see its docstring for the "
                "method; the landmark table is `benchmarks.ict.LANDMARK_POINTS`).", "",
                *[f"- {line.lstrip('# ')}" for line in head[:4]],
                f"- wall time {wall / 60:.1f} min", "", tables.text.strip(), "",
                "### Per head", "", "```", *head[4:], "```", ""]
        write_result(args.md, "\n".join(page))
    if args.json:
        doc = {"detector": det.name, "real_detector": det.real, "draw": draw, "seeds": seeds,
               "commit": git_commit(), "wall_seconds": wall, "goals": GOALS,
               "landmark_table": {k: list(v[:2]) + [v[2]] for k, v in ict.LANDMARK_POINTS.items()},
               "summary": summary, "cases": cases, "cloning": pairs, "noise": noise_rows}
        write_result(args.json, json.dumps(doc, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
