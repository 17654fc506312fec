#!/usr/bin/env python
"""Automatic feature points on heads the main benchmark does not draw: an open mouth, a
smile, a real decimator's mesh, scan noise, a dense mesh.

    python -m benchmarks.bench_find_points_variants [--identities N] [--seed S]
                                                    [--no-clone] [--json PATH] [--md PATH]

:mod:`benchmarks.bench_find_points` measures the detector on neutral ICT-FaceKit heads,
closed-mouthed, full or decimated by vertex clustering.  People bring other heads, and a
detector tuned on one kind says little about the next; this harness draws, for each
random identity (:func:`benchmarks.ict.identity`, ICT's prior), these heads, each with
its eyeballs and its own random placement (:func:`benchmarks.ict.random_placement`):

- ``closed``: the neutral head (the control);
- ``jaw 0.15`` .. ``jaw 1.0``: ICT's ``jawOpen`` at that weight added to the neutral, the
  lips 0.1 to 0.6 eye separations apart (MPEG-4's neutral face has its lips closed, but
  sculpted and scanned heads often have the mouth a little open);
- ``smile 0.5``: ``mouthSmile_L`` and ``_R`` at 0.5 (a face modelled smiling);
- ``eyes shut``: ``eyeBlink_L`` and ``_R`` at 1 (scans are often taken with the eyes
  shut; the detector should say it sees no eye opening);
- ``quadric 0.3``: the Skin decimated to 30 % of its vertices by quadric edge collapse
  (``fast-simplification``, as Blender's or MeshLab's decimators do; no vertex is an
  original one);
- ``noise 0.2 mm``: every Skin vertex moved by Gaussian noise of 0.2 mm per axis (a
  scan's);
- ``dense x4``: each Skin triangle split in four (about 45,000 Skin vertices);
- ``seams``: the Skin cut into three texture islands, each border vertex given once per
  island (:func:`benchmarks.ict.cut_at_seams`: how a glTF exporter stores a textured
  head);
- ``holes``: three holes of radius 0.1 ES cut in the Skin's front, off the mid line and
  away from the landmark points (a scan's, on the cheeks and brows); ``nose hole``: one
  of radius 0.15 ES on the nose tip (a shiny tip's), which the detector should refuse
  with its reason rather than read.

Truth: the points ICT's 68 landmarks define (:data:`benchmarks.ict.LANDMARK_POINTS`) on
the head's own surface (posed for the jaw, smile and shut-eye heads, the identity's for
the others), in % of the identity's eye distance ES0, measured in the head frame (the
placement undone); "said": the heads whose found points carry a note for the user (an
open mouth, an eye with no opening seen).  Cloning (unless ``--no-clone``; the heads
that keep ICT's vertices: closed, jaw, smile, noise): the eight expressions of :mod:`benchmarks.bench_clone_ict`
from identity :data:`benchmarks.bench_find_points.SOURCE_SEED` onto the head with its
found points put in the source's convention (as ``mpeg4fba clone`` does) and with the
landmark points (:func:`benchmarks.ict.landmark_truth`), the ratio of the two.

Reads ``<shared>/data/ict-facekit`` in place; says so and exits 0 when it is absent.
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import json
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import ict  # noqa: E402
from benchmarks import bench_find_points as B  # noqa: E402
from mpeg4fba.fba.face import FaceMesh  # noqa: E402
from mpeg4fba.fba.featurepoints import FeaturePointSet  # noqa: E402

#: The fixed draw (case seeds), for comparing runs; judge changes on ``--seed``.
VARIANT_SEEDS = tuple(B.fresh_seeds(8080, 6))
#: ICT expressions added to the neutral, by variant name.
POSES = {"jaw 0.15": {"jawOpen": 0.15}, "jaw 0.3": {"jawOpen": 0.3},
         "jaw 0.6": {"jawOpen": 0.6}, "jaw 1.0": {"jawOpen": 1.0},
         "smile 0.5": {"mouthSmile_L": 0.5, "mouthSmile_R": 0.5},
         "eyes shut": {"eyeBlink_L": 1.0, "eyeBlink_R": 1.0}}
#: (the later additions last: each head's placement is the next draw of its person's rng)
VARIANTS = ("closed", "jaw 0.15", "jaw 0.3", "jaw 0.6", "jaw 1.0", "smile 0.5", "quadric 0.3",
            "noise 0.2 mm", "dense x4", "seams", "holes", "nose hole", "eyes shut")
#: The variants whose heads keep ICT's vertices, so the cloning has its truth (not the
#: shut eyes: their landmark lids give a FAPU IRISD0 of 0 or less, which the cloner
#: refuses, saying the eyes may be closed).
CLONED = ("closed", *(p for p in POSES if p != "eyes shut"), "noise 0.2 mm")
#: Scan noise, cm per axis (ICT is in cm at life size).
NOISE_CM = 0.02


def subdivide(V: np.ndarray, T: np.ndarray) -> tuple:
    """(V', T'): each triangle split in four at its edges' midpoints (shared edges share
    their midpoint)."""
    e = np.sort(np.r_[T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]], axis=1)
    edges, inv = np.unique(e, axis=0, return_inverse=True)
    inv = inv.ravel()
    mid = len(V) + np.arange(len(edges))
    m = len(T)
    a, b, c = mid[inv[:m]], mid[inv[m:2 * m]], mid[inv[2 * m:]]
    V2 = np.r_[V, 0.5 * (V[edges[:, 0]] + V[edges[:, 1]])]
    T2 = np.r_[np.c_[T[:, 0], a, c], np.c_[a, T[:, 1], b], np.c_[c, b, T[:, 2]], np.c_[a, b, c]]
    return V2, T2


def _with_skin(face, V: np.ndarray, T: np.ndarray):
    out = copy.deepcopy(face)
    out.meshes["Skin"] = FaceMesh("Skin", V, T, face.meshes["Skin"].parent)
    return out


def make_head(data, V: np.ndarray, variant: str, seed: int) -> tuple:
    """(face in the head frame, the vertices the landmarks are read on)."""
    name = f"ICT-r{seed}-{variant.replace(' ', '')}"
    if variant in POSES:
        Vp = V + sum(w * data.expressions[k] for k, w in POSES[variant].items())
        return ict.ict_face(data, Vp, name=name), Vp
    if variant == "quadric 0.3":
        from benchmarks.bench_clone_pairs import quadric_target
        return quadric_target(data, V, 0.3, name)[0], V
    face = ict.ict_face(data, V, name=name)
    skin = face.meshes["Skin"]
    if variant == "noise 0.2 mm":
        rng = np.random.default_rng([seed, 3])
        return _with_skin(face, skin.vertices + rng.normal(0.0, NOISE_CM, skin.vertices.shape),
                          skin.triangles), V
    if variant == "dense x4":
        return _with_skin(face, *subdivide(skin.vertices, skin.triangles)), V
    if variant == "seams":
        return ict.cut_at_seams(face)[0], V
    if variant in ("holes", "nose hole"):
        return _with_skin(face, skin.vertices, _holes(face, variant, seed)), V
    return face, V


def _holes(face, variant: str, seed: int) -> np.ndarray:
    """The Skin's triangles with holes cut: "holes", three of radius 0.1 ES on the face's
    front, 0.25 ES or more from the mid line and from every landmark point (a scan's
    holes on the cheeks and brows); "nose hole", one of radius 0.15 ES on the nose tip."""
    skin = face.meshes["Skin"]
    c = skin.vertices[skin.triangles].mean(1)
    P = face.points
    es = float(np.linalg.norm(P["3.5"] - P["3.6"]))
    if variant == "nose hole":
        centres, radius = P["9.3"][None], 0.15
    else:
        L = np.array([P[k] for k in B.LANDMARK_IDS if k in P])
        front = np.flatnonzero((c[:, 2] > np.percentile(c[:, 2], 70))
                               & (np.abs(c[:, 0]) > 0.25 * es))
        far = np.min(np.linalg.norm(c[front][:, None] - L[None], axis=2), axis=1) > 0.35 * es
        rng = np.random.default_rng([seed, 5])
        centres, radius = c[rng.choice(front[far], 3, replace=False)], 0.1
    d = np.min(np.linalg.norm(c[:, None] - centres[None], axis=2), axis=1)
    return skin.triangles[d > radius * es]


def run_head(det, data, source, src_found, ident, variant: str, pl, clone: bool) -> dict:
    face, Vl = make_head(data, ident.vertices, variant, ident.seed)
    truth = ict.landmark_points(data, Vl)
    world = ict.placed_face(face, pl, eyes=True, name=face.name)
    res = {"seed": ident.seed, "variant": variant, "placement": pl.label,
           "vertices": int(sum(len(m.vertices) for m in world.meshes.values()))}
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = det.find(world)
    except Exception as e:                                       # noqa: BLE001 (counted)
        res["raised"] = f"{type(e).__name__}: {e}"
        return res
    res["time"] = time.perf_counter() - t0
    res["notes"] = list(found.notes)
    P = found.points
    res["errors"] = {k: float(np.linalg.norm(pl.undo(P[k]) - truth[k]) / ident.es * 100)
                     for k in B.LANDMARK_IDS if k in P}
    conf = dict(found.confidence)
    res["lowest_confidence"] = min(conf.items(), key=lambda kv: kv[1]) if conf else None
    if clone and variant in CLONED:
        from mpeg4fba.cloning.autopoints import matched_points
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = matched_points(world, found, source, source_found=src_found)
        auto = FeaturePointSet({k: pl.undo(m[k]) for k in m}, dict(m.vertices))
        res["auto"] = B.clone_error(data, source, face, auto, True)
        res["landmark"] = B.clone_error(data, source, face, ict.landmark_truth(data, Vl), True)
    return res


def report(rows: list) -> dict:
    print("\n### Found points against the landmark points, by kind of head (% of ES0)\n")
    print("| head | heads | raised | said | median | p95 | max | worst point | without the contour: "
          "p95 / max | time median (s) |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    out = {}
    contour = set(ict.LANDMARK_CONTOUR)
    for v in VARIANTS:
        r = [x for x in rows if x["variant"] == v]
        ok = [x for x in r if "errors" in x]
        e = [d for x in ok for d in x["errors"].values()]
        e_nc = [d for x in ok for k, d in x["errors"].items() if k not in contour]
        s, snc = B.stats(e), B.stats(e_nc)
        worst = max(((d, k) for x in ok for k, d in x["errors"].items()), default=(float("nan"), "-"))
        t = B.stats([x["time"] for x in ok])
        said = sum(bool(x.get("notes")) for x in ok)
        print(f"| {v} | {len(r)} | {len(r) - len(ok)} | {said} | {B.fmt(s[0])} | {B.fmt(s[1])} | {B.fmt(s[2])} "
              f"| {worst[1]} | {B.fmt(snc[1])} / {B.fmt(snc[2])} | {B.fmt(t[0])} |")
        out[v] = {"heads": len(r), "raised": len(r) - len(ok), "said": said, "points": s, "no_contour": snc,
                  "worst_point": worst[1], "time": t[0]}
    cl = [x for x in rows if "auto" in x and "landmark" in x]
    if cl:
        print("\n### Cloning with found points against with landmark points (% of ES0)\n")
        print("| head | clonings | raised | auto mean / max (median) | landmark mean / max (median) "
              "| ratio mean (median / worst) | ratio max (median / worst) |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for v in CLONED:
            r = [x for x in cl if x["variant"] == v]
            good = [x for x in r if "max" in x["auto"] and "max" in x["landmark"]]
            if not r:
                continue
            rm = B.stats([x["auto"]["mean"] / x["landmark"]["mean"] for x in good])
            rx = B.stats([x["auto"]["max"] / x["landmark"]["max"] for x in good])
            am = B.stats([x["auto"]["mean"] for x in good])
            ax = B.stats([x["auto"]["max"] for x in good])
            lm = B.stats([x["landmark"]["mean"] for x in good])
            lx = B.stats([x["landmark"]["max"] for x in good])
            print(f"| {v} | {len(r)} | {len(r) - len(good)} | {B.fmt(am[0], 3)} / {B.fmt(ax[0])} "
                  f"| {B.fmt(lm[0], 3)} / {B.fmt(lx[0])} | {B.fmt(rm[0])} / {B.fmt(rm[2])} "
                  f"| {B.fmt(rx[0])} / {B.fmt(rx[2])} |")
            out[v]["cloning"] = {"n": len(r), "raised": len(r) - len(good), "ratio_mean": rm,
                                 "ratio_max": rx, "auto_max": ax, "landmark_max": lx}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--identities", type=int, default=None,
                    help=f"how many identities (default {len(VARIANT_SEEDS)})")
    ap.add_argument("--seed", type=int, default=None,
                    help="a fresh draw from this seed (default: the fixed draw VARIANT_SEEDS)")
    ap.add_argument("--no-clone", action="store_true", help="points only, no cloning")
    ap.add_argument("--json", type=Path, default=None, help="write every head's figures here")
    ap.add_argument("--md", type=Path, default=None, help="write the tables here (markdown)")
    args = ap.parse_args(argv)
    data = ict.load_or_say()
    if data is None:
        return 0
    n = args.identities or len(VARIANT_SEEDS)
    if args.seed is None:
        if n > len(VARIANT_SEEDS):
            ap.error(f"the fixed draw has {len(VARIANT_SEEDS)} identities; give --seed")
        seeds, draw = list(VARIANT_SEEDS[:n]), "the fixed draw (VARIANT_SEEDS)"
    else:
        seeds, draw = B.fresh_seeds(args.seed, n), f"a fresh draw, --seed {args.seed}"
    det = B.load_detector()
    if not det.real:
        print("the detector is not there yet: nothing to measure")
        return 0
    progress = B._Tee(sys.stdout)
    t_start = time.perf_counter()
    with contextlib.redirect_stdout(progress):
        print(f"# find_feature_points on heads the main benchmark does not draw: {n} identities "
              f"x {len(VARIANTS)} heads, {draw}")
        print(f"command: python -m benchmarks.bench_find_points_variants "
              f"{' '.join(argv if argv is not None else sys.argv[1:])}")
        print(f"commit {B.git_commit()}, python {platform.python_version()}, case seeds {seeds}")
        source = ict.ict_face(data, ict.identity(data, B.SOURCE_SEED), name=f"ICT-{B.SOURCE_SEED}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            src_found = det.find(ict.placed_face(source, None, name=source.name))
        rows = []
        for i, seed in enumerate(seeds):
            ident = B.draw_identity(data, i, seed)
            rng = np.random.default_rng([seed, 4])
            for v in VARIANTS:
                r = run_head(det, data, source, src_found, ident, v, ict.random_placement(rng),
                             not args.no_clone)
                rows.append(r)
                if "raised" in r:
                    line = f"raised {r['raised'][:150]}"
                else:
                    e = r["errors"]
                    k = max(e, key=e.get)
                    line = (f"{r['time']:.2f} s, median {np.median(list(e.values())):.2f} max "
                            f"{e[k]:.2f} ({k}) % ES0")
                    if "auto" in r:
                        a, l = r["auto"], r["landmark"]
                        line += (f"; cloned auto {a.get('mean', float('nan')):.3f}/"
                                 f"{a.get('max', float('nan')):.2f}, landmark "
                                 f"{l.get('mean', float('nan')):.3f}/{l.get('max', float('nan')):.2f}")
                print(f"  id{i} ({seed}) {v}, {r['placement']}: {line}", flush=True)
    wall = time.perf_counter() - t_start
    tables = B._Tee(sys.stdout)
    with contextlib.redirect_stdout(tables):
        summary = report(rows)
        print(f"\nwall time {wall / 60:.1f} min ({n} identities, {len(rows)} heads)")
    if args.md:
        head = progress.text.splitlines()
        page = ["# Automatic feature points on heads the main benchmark does not draw "
                "(bench_find_points_variants)", "",
                "Written by `python -m benchmarks.bench_find_points_variants` (see its docstring).", "",
                *[f"- {line.lstrip('# ')}" for line in head[:3]], f"- wall time {wall / 60:.1f} min",
                "", tables.text.strip(), "", "### Per head", "", "```", *head[3:], "```", ""]
        B.write_result(args.md, "\n".join(page))
    if args.json:
        doc = {"draw": draw, "seeds": seeds, "commit": B.git_commit(), "wall_seconds": wall,
               "summary": summary, "heads": rows}
        B.write_result(args.json, json.dumps(doc, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
