#!/usr/bin/env python
"""Quality of Facial Motion Cloning on real faces: ICT-FaceKit identities.

    python benchmarks/bench_clone_ict.py [--quick] [--all] [--seeds A B] [--fraction F]
                                         [--oracle] [--pairs [--variant V] [--same-mesh]]

Reads ``<shared>/data/ict-facekit`` in place (``$MPEG4FBA_SHARED`` or ``<repo>/../shared``;
the script says so and exits 0 when it is absent).  Faces (:mod:`benchmarks.ict`):
identity A = ICT neutral + identity modes with weights ~ N(0, 1) (seed A, default 1),
identity B likewise (seed B, default 2), and B with its skin decimated to ``--fraction``
(default 0.25: 11,248 -> about 2,800 skin vertices, another topology; each kept vertex is
an original one, so its ground truth is known exactly).

ICT's expressions are identity-independent deltas, so cloning expression E from A onto
B has the exact ground truth ``B + delta_E`` when the motion is copied as is (**scaling
off**, ``scale_motion=False``: a test of the mapping alone).  With **scaling on** (the
paper's FAPU normalisation) the cloned motion is, by design, A's motion resized to B's
proportions, so its difference from ``delta_E`` is partly intended; it is reported too.

For each expression (default the eight of the issue; ``--all``: all 53) the source skin
motion goes through ``FacialMotionCloner.map_skin`` and the result on B's skin is compared
with the truth: mean, p95 and max of the vertex error as % of B's inter-ocular distance
(|3.5 - 3.6|), per region (:func:`benchmarks.ict.skin_regions`: mouth, eyes, brows, rest,
the ICT ``face`` area only) and over all of it, and flipped triangles (triangles of B's
skin whose normal turns by more than 90 degrees, cloned vs truth).  Rigid parts: jawOpen
as a one-table FAT on A (FAP 3 at 1024), cloned with ``clone()``: the rotation of the
Transform installed for B's lower teeth against the rotation fitted to B's true lower
teeth motion.

``--oracle`` replaces the alignment by the true correspondence (every target vertex put
where its original vertex is on the source: possible here because the faces come from
one mesh), to show what the rest of the pipeline does with a perfect alignment: in the
paper's 2D alignment (the surface refinement skipped), and as the surface points of the
default cloner (registration result replaced by the truth).  The truth goes in through
the cloner's ``correspondence=`` keyword (:func:`true_correspondence`).

Each table of the default cloner is followed by its **registration error**: how far the
surface alignment put each target skin vertex from where its original vertex is on the
source (% of the source's normalised inter-ocular distance), per region: what limits
the mapping, since closest points and a smoothness prior can only guess where a vertex
belongs along a surface.

Variants (all but ``--quick``): the default cloner (surface alignment: warp, neck cuts
pinned, registration, weights on the surface); without the registration; its thin plate
alone (``membrane=0``); without the facing term of the surface weights (``facing=0``);
without the finer fit (``refine=False``); without the neck pinning; the surface alignment with the paper's 2D interpolation; the warp and
closest point alone with the 2D interpolation (the default before the registration); the
paper's 2D
alignment and interpolation ``alignment="paper"``, also with its overlap rule
``overlap="front"`` and its closest-triangle search over all triangles
``outside="global"``; ``positions="regional"``; ``support=0`` (no anti-aliasing).

``--pairs``: the default cloner (or ``--variant NAME``), scaling off, onto the decimated
target (``--same-mesh``: the full one), for several identity pairs (:data:`PAIRS`), to
show how much one pair's figures say.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks import ict  # noqa: E402
from mpeg4fba.cloning import FacialMotionCloner, clone  # noqa: E402
from mpeg4fba.cloning.correspondence import paper_alignment, surface_alignment  # noqa: E402
from mpeg4fba.cloning.rigid import fit_rigid  # noqa: E402
from mpeg4fba.fba.fat import FAT  # noqa: E402

EXPRESSIONS = ("jawOpen", "eyeBlink_L", "mouthSmile_L", "mouthFunnel", "mouthPucker",
               "browInnerUp_L", "cheekPuff_L", "noseSneer_L")
REGIONS = ("mouth", "eyes", "brows", "rest")
VARIANTS = {
    "default": {},
    "register=False": {"register": False},
    "membrane=0": {"membrane": 0.0},
    "facing=0": {"facing": 0.0},
    "refine=False": {"refine": False},
    "neck=False": {"neck": False},
    "interpolation=2d": {"interpolation": "2d"},
    "warp only, 2d": {"register": False, "neck": False, "interpolation": "2d"},
    "alignment=paper": {"alignment": "paper"},
    "paper, overlap=front": {"alignment": "paper", "overlap": "front"},
    "paper, outside=global": {"alignment": "paper", "outside": "global"},
    "positions=regional": {"positions": "regional"},
    "support=0": {"support": 0.0},
}
#: Identity pairs (source seed, target seed) of the robustness table (``--pairs``).
PAIRS = ((1, 2), (2, 1), (3, 4), (5, 6), (7, 8), (9, 10))


def source_motion(cloner, face, deltas: dict) -> np.ndarray:
    """(Ns, 3K) source skin motion from per-mesh (K, n, 3) deltas."""
    k = next(iter(deltas.values())).shape[0]
    out = np.zeros((len(cloner.src.vertices), k, 3))
    for mesh, (first, n) in cloner.source_skin.items():
        out[first:first + n] = np.moveaxis(deltas[mesh], 0, 1)
    return out.reshape(len(out), 3 * k)


def region_rows(target) -> dict:
    """Rows of the target's skin measured per region (:data:`REGIONS`); "rest" is kept to
    ICT's front of the face."""
    regions = ict.skin_regions(target)
    out = {r: regions[r] for r in REGIONS}
    out["rest"] = np.intersect1d(out["rest"], target.regions[ict.SKIN_FRONT])
    return out


def evaluate(cloner, source, target, names, data) -> dict:
    """Per expression: errors (% IOD) per region and flipped triangle counts."""
    full = data.expression_deltas(names)
    src = ict.split_deltas(source, full)
    truth = ict.split_deltas(target, full)["Skin"]                   # (K, n, 3)
    mapped = cloner.map_skin(source_motion(cloner, source, src))
    first, n = cloner.target_skin["Skin"]
    got = mapped[first:first + n].reshape(n, len(names), 3).transpose(1, 0, 2)
    iod = float(np.linalg.norm(target.points["3.5"] - target.points["3.6"]))
    regions = region_rows(target)
    front = np.concatenate([regions[r] for r in REGIONS])
    skin = target.meshes["Skin"]
    out = {}
    for i, name in enumerate(names):
        err = np.linalg.norm(got[i] - truth[i], axis=1) / iod * 100
        row = {}
        for r in REGIONS:
            e = err[regions[r]]
            row[r] = (e.mean(), np.percentile(e, 95), e.max())
        e = err[front]
        row["all"] = (e.mean(), np.percentile(e, 95), e.max())
        row["over2"] = int((e > 2.0).sum())
        row["n"] = len(e)
        row["flipped"] = (ict.flipped_triangles(skin.vertices, skin.vertices + got[i], skin.triangles),
                          ict.flipped_triangles(skin.vertices, skin.vertices + truth[i], skin.triangles))
        out[name] = row
    return out


def print_table(title: str, results: dict) -> dict:
    print(f"\n{title}")
    print(f"{'expression':16s} " + " ".join(f"{r + ' mean/p95/max':>22s}" for r in REGIONS + ("all",))
          + "  flipped (clone/truth)")
    worst = {"mean": 0.0, "max": 0.0, "flip": 0, "over2": 0, "n": 0}
    means, maxes = [], []
    for name, row in results.items():
        cells = " ".join(f"{row[r][0]:6.3f}/{row[r][1]:6.3f}/{row[r][2]:6.3f}" for r in REGIONS + ("all",))
        f = row["flipped"]
        print(f"{name:16s} {cells}  {f[0]}/{f[1]}")
        means.append(row["all"][0])
        maxes.append(row["all"][2])
        worst["flip"] = max(worst["flip"], f[0] - f[1])
        worst["over2"] += row["over2"]
        worst["n"] += row["n"]
    worst["mean"], worst["max"] = float(np.mean(means)), float(np.max(maxes))
    print(f"{'over these':16s} mean {worst['mean']:.3f} % IOD, max {worst['max']:.3f} % IOD, "
          f"flipped beyond truth: {worst['flip']}; vertex errors over 2 %: {worst['over2']} of "
          f"{worst['n']:,}")
    return worst


def rigid_jaw(data, source, target, **options) -> tuple:
    """(recovered angle, true angle) of the lower teeth under jawOpen, degrees."""
    src = source
    src.fat = ict.jaw_fat(data, src)
    src.invalidate()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = clone(src, target, **options)
    rot = [e for e in out.fat[3].transforms if e.field == "rotation"]
    recovered = float(np.degrees(rot[0].rotation[3] * 1024)) if rot else float("nan")
    x = target.world_vertices("LowerTeeth")
    true = ict.split_deltas(target, data.expressions["jawOpen"])["LowerTeeth"]
    fit = fit_rigid(x, x + true)
    src.fat = FAT()
    src.invalidate()
    return recovered, float(np.degrees(fit.angle)), rot[0].transform if rot else None


def true_correspondence(source, target, options):
    """The cloner's correspondence step with the truth in it (``FacialMotionCloner(...,
    correspondence=true_correspondence)``): the paper's alignment with each target skin
    vertex put where its original vertex is on the source (ICT ids kept in the faces'
    ``ict_ids:`` regions), then, with ``alignment="surface"``, the surface alignment with
    the registration's result replaced by the true surface points."""
    corr = paper_alignment(source, target, options.triangulation)
    aligned, depth = corr.aligned.copy(), corr.aligned_depth.copy()
    for mesh, (ft, nt) in target.offsets.items():
        if mesh not in source.offsets:
            continue
        fs, _ = source.offsets[mesh]
        tid = target.face.regions[ict.IDS_PREFIX + mesh]
        sid = source.face.regions[ict.IDS_PREFIX + mesh]
        pos = np.searchsorted(sid, tid)
        aligned[ft:ft + nt] = source.space.uv[fs + pos]
        depth[ft:ft + nt] = source.space.depth[fs + pos]
    corr = dataclasses.replace(corr, aligned=aligned, aligned_depth=depth)
    if options.alignment == "surface":
        corr = surface_alignment(source, target, corr, options, register=true_registration)
    return corr


def true_registration(source, target, warped, **options) -> np.ndarray:
    """A stand-in for :func:`~mpeg4fba.cloning.correspondence.register_skin` returning
    the true surface points of the target's skin."""
    out = warped.copy()
    ft, nt = target.offsets["Skin"]
    out[ft:ft + nt] = _true_surface_points(source, target)
    return out


def _true_surface_points(source, target) -> np.ndarray:
    """(n, 3) where each target skin vertex's original vertex is on the source's skin, in
    the source's normalised space (the faces share ICT's numbering); ``source`` and
    ``target`` are the cloner's skins."""
    fs, _ = source.offsets["Skin"]
    tid = target.face.regions[ict.IDS_PREFIX + "Skin"]
    sid = source.face.regions[ict.IDS_PREFIX + "Skin"]
    return source.normalised[fs + np.searchsorted(sid, tid)]


def registration_error(cloner, target) -> dict:
    """Per region (mean, max) distance of the surface points from the truth, % IOD."""
    ft, nt = cloner.tgt.offsets["Skin"]
    iod = float(np.linalg.norm(np.subtract(*cloner.src.space.normalise(
        np.array([cloner.source.points["3.5"], cloner.source.points["3.6"]])))))
    err = np.linalg.norm(cloner.surface_points[ft:ft + nt]
                         - _true_surface_points(cloner.src, cloner.tgt), axis=1) / iod * 100
    return {r: (float(err[idx].mean()), float(err[idx].max()))
            for r, idx in region_rows(target).items()}


def robustness(data, names, fraction: float, variant: str = "default",
               same_mesh: bool = False) -> int:
    """One cloner (:data:`VARIANTS`) over :data:`PAIRS`, decimated targets (or the full
    mesh with ``same_mesh``), scaling off."""
    onto = "the full mesh" if same_mesh else f"the decimated target (fraction {fraction})"
    print(f"[{variant}] scaling off, onto {onto}, {len(names)} expressions, % of IOD")
    print(f"{'pair':8s} {'mean':>6s} {'p95':>6s} {'max':>6s}  worst region   flipped beyond truth"
          f"  errors > 2 %")
    worst = []
    for a, b in PAIRS:
        A = ict.ict_face(data, ict.identity(data, a), name=f"ICT-{a}")
        if same_mesh:
            D = ict.ict_face(data, ict.identity(data, b), name=f"ICT-{b}")
        else:
            D = ict.ict_face_decimated(data, ict.identity(data, b), fraction,
                                       name=f"ICT-{b}-decimated")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cloner = FacialMotionCloner(A, D, scale_motion=False, **VARIANTS[variant])
        res = evaluate(cloner, A, D, names, data)
        mean = float(np.mean([r["all"][0] for r in res.values()]))
        p95 = float(np.max([r["all"][1] for r in res.values()]))
        top = max(((r[g][2], g, name) for name, r in res.items() for g in REGIONS))
        flips = max(r["flipped"][0] - r["flipped"][1] for r in res.values())
        over = sum(r["over2"] for r in res.values())
        total = sum(r["n"] for r in res.values())
        worst.append(top[0])
        print(f"{a:>2d} -> {b:<2d} {mean:6.3f} {p95:6.3f} {top[0]:6.2f}  {top[1]:5s} {top[2]:16s} "
              f"{flips:3d}   {over} of {total:,}")
    print(f"median of the maxima {np.median(worst):.2f} % IOD")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="default cloner only, no variants")
    ap.add_argument("--all", action="store_true", help="all 53 expressions")
    ap.add_argument("--seeds", type=int, nargs=2, default=(1, 2))
    ap.add_argument("--fraction", type=float, default=0.25)
    ap.add_argument("--pairs", action="store_true",
                    help="the robustness table over several identity pairs, then exit")
    ap.add_argument("--variant", default="default", choices=sorted(VARIANTS),
                    help="the cloner of --pairs (default: the default cloner)")
    ap.add_argument("--same-mesh", action="store_true",
                    help="--pairs onto the full mesh instead of the decimated one")
    ap.add_argument("--oracle", action="store_true",
                    help="align by the true correspondence (default cloner, and support=0)")
    args = ap.parse_args(argv)
    data = ict.load_or_say()
    if data is None:
        return 0
    names = list(data.expressions) if args.all else list(EXPRESSIONS)
    if args.pairs:
        return robustness(data, names, args.fraction, args.variant, args.same_mesh)
    a, b = args.seeds
    A = ict.ict_face(data, ict.identity(data, a), name=f"ICT-{a}")
    B = ict.ict_face(data, ict.identity(data, b), name=f"ICT-{b}")
    D = ict.ict_face_decimated(data, ict.identity(data, b), args.fraction, name=f"ICT-{b}-decimated")
    print(f"source {A.name}: {sum(len(m.vertices) for m in A.meshes.values()):,} vertices; "
          f"targets {B.name} (skin {len(B.meshes['Skin'].vertices):,}) and {D.name} "
          f"(skin {len(D.meshes['Skin'].vertices):,})")
    variants = {"default": {}} if args.quick else VARIANTS
    extra = {}
    if args.oracle:
        extra = {"correspondence": true_correspondence}
        variants = {"oracle alignment": {"alignment": "paper", **extra},
                    "oracle alignment, support=0": {"alignment": "paper", "support": 0.0,
                                                    **extra},
                    "oracle surface points": extra}
    summary = []
    for label, opts in variants.items():
        for scale in (False, True):
            for tname, target in (("same topology", B), ("decimated", D)):
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    cloner = FacialMotionCloner(A, target, scale_motion=scale, **opts)
                setup = time.perf_counter() - t0
                res = evaluate(cloner, A, target, names, data)
                worst = print_table(f"[{label}] scaling {'on' if scale else 'off'}, {A.name} -> "
                                    f"{target.name} ({tname}); set-up {setup:.2f} s; "
                                    f"% of IOD", res)
                summary.append((label, scale, tname, worst))
                if label == "default" and not scale:
                    reg = registration_error(cloner, target)
                    print("registration error (% IOD, mean / max): " + ", ".join(
                        f"{r} {m:.2f} / {x:.2f}" for r, (m, x) in reg.items()))
    rec, true, name = rigid_jaw(data, A, B, **extra)
    print(f"\nrigid parts: jawOpen lower teeth on {B.name}: recovered rotation {rec:.2f} deg "
          f"(Transform {name}), true {true:.2f} deg, difference {abs(rec - true):.2f} deg")
    rec_d, true_d, _ = rigid_jaw(data, A, D, **extra)
    print(f"             on {D.name}: recovered {rec_d:.2f} deg, true {true_d:.2f} deg")
    print("\nsummary (mean / max % IOD over the expressions, flipped beyond truth):")
    for label, scale, tname, w in summary:
        print(f"  {label:22s} scaling {'on ' if scale else 'off'} {tname:14s} "
              f"{w['mean']:.3f} / {w['max']:.3f}  {w['flip']}  (over 2 %: {w['over2']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
