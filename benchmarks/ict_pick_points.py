"""Choose the MPEG-4 feature points of the ICT-FaceKit generic head, reproducibly.

    python benchmarks/ict_pick_points.py [--shared DIR] [--out JSON] [--plot PNG] [--check]

Derives a vertex id of the generic neutral for each feature point from the data (rules
below, one per point, also written into the JSON), checks them (symmetric pairs mirror
in x, upper/lower lip and lid points against the jawOpen / eyeBlink deltas), and writes
``spec_fixtures/ict/feature_points.json`` (our choice of ids; no data is copied).
``--plot`` draws the points on the head (front and side view, mouth and eye close-ups);
``--check`` only compares the derived ids with the JSON (exit status 1 when they differ).

Left is the face's own left, +x.  Multi-PIE / iBUG 68 landmarks (``LMk``): 0-16 jaw
contour, 17-21 right brow, 22-26 left brow, 27-30 nose bridge, 31-35 nostril base, 36-41
right eye, 42-47 left eye, 48-59 outer lip, 60-67 inner lip (checked: LM0..LM7 and the
"right" features have x < 0).  A point whose mirror partner is derived by the same rule
takes the vertex nearest its mirror image (must be within 0.005 cm; the mesh is
symmetric to 0.03 cm everywhere).

General helpers of the rules: the *slab* at x0 is the set of front-area (ICT ``face``
range) vertices of a window with |x - x0| < 0.015 ES0; the mesh edges inside it fall
into pieces, and the *upper piece* is the one holding the slab's highest vertex, the
*lower piece* the one holding its lowest (the lips, and the lids, are separate surfaces
that touch without sharing edges).  "Lowest (ties: front-most)": of the vertices within
0.025 cm of the lowest height, the front-most (closed lips and lids touch along a flat
band; this is its front edge, where the contour is seen from the front); likewise for
"highest".  The *front vertex at (x, y)* is the front-area vertex nearest to the
front-most point where the line {(x, y, z)} meets the Skin.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Optional

import numpy as np
from scipy.sparse.csgraph import connected_components

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.ict import (FP_JSON, IctData, vertex_adjacency, ict_face, load_ict,  # noqa: E402
                            line_hits, mesh_layout, spine_top, vertex_normals)
from mpeg4fba.fba.featurepoints import point_order  # noqa: E402

#: (left point, right point) pairs that mirror each other in x.
PAIRS = [("2.4", "2.5"), ("2.6", "2.7"), ("2.8", "2.9"), ("2.11", "2.12"), ("2.13", "2.14"),
         ("3.1", "3.2"), ("3.3", "3.4"), ("3.5", "3.6"), ("3.7", "3.12"), ("3.11", "3.8"),
         ("3.9", "3.10"), ("3.13", "3.14"), ("4.1", "4.2"), ("4.3", "4.4"), ("4.5", "4.6"),
         ("5.1", "5.2"), ("5.3", "5.4"), ("8.3", "8.4"), ("8.5", "8.6"), ("8.7", "8.8"),
         ("8.10", "8.9"), ("9.1", "9.2"), ("9.5", "9.4"), ("9.7", "9.6"), ("11.3", "11.2")]
MIDLINE = ["2.1", "2.2", "2.3", "2.10", "8.1", "8.2", "9.3", "9.15", "9.8", "9.9", "9.10",
           "9.11", "11.1", "6.1"]
MIRROR_TOL = 0.005


class Picker:
    """The geometry the rules need, computed once from the generic neutral."""

    def __init__(self, data: IctData):
        self.data = data
        self.V = data.neutral
        self.layout = mesh_layout(data)
        a, b = data.ranges["face"]
        self.front = np.zeros(data.n_vertices, dtype=bool)
        self.front[a:b + 1] = True
        skin = self.layout.ids["Skin"]
        self.skin_tris = skin[self.layout.triangles["Skin"]]
        self.N = vertex_normals(self.V, self.skin_tris)
        self.A = vertex_adjacency(self.skin_tris, data.n_vertices)
        self.A_all = vertex_adjacency(data.triangles, data.n_vertices)
        self.lm = data.landmarks
        self.ids: dict = {}
        self.rules: dict = {}

    # -- bookkeeping ---------------------------------------------------------------------
    def set(self, fp: str, vertex: int, rule: str) -> None:
        self.ids[fp] = int(vertex)
        self.rules[fp] = rule

    def P(self, fp: str) -> np.ndarray:
        return self.V[self.ids[fp]]

    def mesh_ids(self, mesh: str) -> np.ndarray:
        return self.layout.ids[mesh]

    def mirror(self, left: str, right: str) -> None:
        """``right`` := the vertex nearest the mirror image of ``left`` (same mesh)."""
        v = self.ids[left]
        mesh, _ = self.layout.locate(v)[0]
        cand = self.mesh_ids(mesh)
        target = self.V[v] * [-1, 1, 1]
        d = np.linalg.norm(self.V[cand] - target, axis=1)
        k = int(np.argmin(d))
        if d[k] > MIRROR_TOL:
            raise AssertionError(f"{right}: no vertex within {MIRROR_TOL} of the mirror of {left}")
        self.set(right, cand[k], f"mirror of {left} (the vertex nearest its image in x)")

    # -- geometric helpers -----------------------------------------------------------------
    @property
    def es(self) -> float:
        return float(self.P("3.5")[0] - self.P("3.6")[0])

    def slab(self, window: np.ndarray, x0: float) -> tuple:
        """(upper piece, lower piece) of the slab at x0 of ``window`` (a vertex mask)."""
        m = np.flatnonzero(window & self.front & (np.abs(self.V[:, 0] - x0) < 0.015 * self.es))
        _, lab = connected_components(self.A[m][:, m], directed=False)
        top = lab[np.argmax(self.V[m, 1])]
        bottom = lab[np.argmin(self.V[m, 1])]
        if top == bottom:
            raise AssertionError(f"the slab at x = {x0:.3f} is one piece")
        return m[lab == top], m[lab == bottom]

    def lowest(self, ids: np.ndarray, tol: float = 0.025) -> int:
        """The lowest vertex of ``ids``; of those within ``tol`` (cm) of the lowest height,
        the front-most (closed lips and lids touch along a flat band: its front edge)."""
        y = self.V[ids, 1]
        c = ids[y <= y.min() + tol]
        return int(c[np.argmax(self.V[c, 2])])

    def highest(self, ids: np.ndarray, tol: float = 0.025) -> int:
        y = self.V[ids, 1]
        c = ids[y >= y.max() - tol]
        return int(c[np.argmax(self.V[c, 2])])

    def front_vertex(self, x: float, y: float) -> int:
        """The front-area vertex nearest the front-most Skin point on the line (x, y, z)."""
        z = line_hits(self.V, self.skin_tris, x, y)
        if not len(z):
            raise AssertionError(f"no Skin surface at x={x:.3f}, y={y:.3f}")
        point = np.array([x, y, z[-1]])
        cand = np.flatnonzero(self.front)
        return int(cand[np.argmin(np.linalg.norm(self.V[cand] - point, axis=1))])

    # -- the rules ---------------------------------------------------------------------------
    def pick(self) -> dict:
        V, lm, front = self.V, self.lm, self.front
        E = self.data.expressions

        # eyes' pupils first: ES0 scales the windows
        for fp, mesh in (("3.5", "LeftEyeball"), ("3.6", "RightEyeball")):
            ids = self.mesh_ids(mesh)
            self.set(fp, ids[np.argmax(V[ids, 2])],
                     f"centre of the pupil: the front-most (largest z) vertex of {mesh}")
        es = self.es

        # landmarks used as they are
        for fp, k, what in [
                ("2.1", 8, "bottom of the chin (the jaw contour's lowest landmark)"),
                ("2.4", 64, "left inner lip corner"), ("2.5", 60, "right inner lip corner"),
                ("2.11", 9, "left chin corner (jaw contour)"),
                ("2.12", 7, "right chin corner (jaw contour)"),
                ("3.7", 45, "outer corner of the left eye"), ("3.11", 42, "inner corner of the left eye"),
                ("3.8", 39, "inner corner of the right eye"), ("3.12", 36, "outer corner of the right eye"),
                ("4.1", 22, "inner end of the left brow"), ("4.2", 21, "inner end of the right brow"),
                ("4.5", 26, "outer end of the left brow"), ("4.6", 17, "outer end of the right brow"),
                ("8.1", 51, "middle of the outer upper lip contour"),
                ("8.2", 57, "middle of the outer lower lip contour"),
                ("8.3", 54, "left outer lip corner"), ("8.4", 48, "right outer lip corner"),
                ("8.10", 52, "left high point of the Cupid's bow"),
                ("8.9", 50, "right high point of the Cupid's bow"),
                ("9.15", 33, "bottom middle of the nose (subnasale: where the columella meets the lip)"),
                ("9.5", 35, "bottom left edge of the nose (left end of the nostril base)"),
                ("9.4", 31, "bottom right edge of the nose (right end of the nostril base)")]:
            self.set(fp, lm[k], f"Multi-PIE landmark {k}: {what}")
        brow = lm[22:27]
        self.set("4.3", brow[np.argmax(V[brow, 1])],
                 "uppermost point of the left brow: the highest of Multi-PIE landmarks 22-26")
        self.mirror("4.3", "4.4")

        # nose
        self.set("9.3", np.flatnonzero(front)[np.argmax(V[front, 2])],
                 "nose tip: the front-most (largest z) vertex of the face")
        box = (front & (V[:, 0] > 0.5 * self.P("9.5")[0]) & (V[:, 0] < self.P("8.3")[0])
               & (V[:, 1] > self.P("9.15")[1]) & (V[:, 1] < self.P("9.3")[1])
               & (self.N[:, 0] > 0.7))
        c = np.flatnonzero(box)
        self.set("9.1", c[np.argmax(V[c, 0])],
                 "left nostril border (ala): the outermost (largest x) vertex facing sideways "
                 "(normal x > 0.7) between the heights of 9.15 and 9.3, x between half of "
                 "9.5's and the lip corner 8.3's")
        p = self.P("3.11")
        self.set("9.7", self.front_vertex(0.5 * p[0], p[1]),
                 "left upper edge of the nose bone: front vertex at the height of the inner eye "
                 "corner 3.11, halfway between the midline and it")

        # inner lips: the contact line of the closed lips
        lips = front & (V[:, 1] > self.P("8.2")[1]) & (V[:, 1] < self.P("8.1")[1]) \
            & (V[:, 2] > self.P("2.4")[2] - 1.0)
        up, lo = self.slab(lips, self.P("8.1")[0])
        self.set("2.2", self.lowest(up), "middle of the inner upper lip contour: the lowest vertex "
                 "(ties: front-most) of the upper lip in the midline slab")
        self.set("2.3", self.highest(lo), "middle of the inner lower lip contour: the highest vertex "
                 "(ties: front-most) of the lower lip in the midline slab")
        up, _ = self.slab(lips, 0.5 * (self.P("2.2")[0] + self.P("2.4")[0]))
        self.set("2.6", self.lowest(up), "inner upper lip, left: the lowest vertex (ties: front-most) "
                 "of the upper lip in the slab halfway between 2.2 and 2.4")
        _, lo = self.slab(lips, 0.5 * (self.P("2.3")[0] + self.P("2.4")[0]))
        self.set("2.8", self.highest(lo), "inner lower lip, left: the highest vertex (ties: front-"
                 "most) of the lower lip in the slab halfway between 2.3 and 2.4")

        # outer lip midpoints: half the arc length of the landmark contour
        for fp, chain, what in (("8.5", [51, 52, 53, 54], "outer upper lip between 8.1 and 8.3"),
                                ("8.7", [57, 56, 55, 54], "outer lower lip between 8.2 and 8.3")):
            Q = V[lm[chain]]
            seg = np.linalg.norm(np.diff(Q, axis=0), axis=1)
            s = np.r_[0, np.cumsum(seg)]
            half = 0.5 * s[-1]
            i = int(np.searchsorted(s, half) - 1)
            point = Q[i] + (half - s[i]) / seg[i] * (Q[i + 1] - Q[i])
            cand = np.flatnonzero(front)
            self.set(fp, cand[np.argmin(np.linalg.norm(V[cand] - point, axis=1))],
                     f"{what}: the vertex nearest the point at half the arc length of the "
                     f"polyline of landmarks {'-'.join(map(str, chain))}")

        # eyelids, at the pupil's x
        eye_lm = lm[42:48]
        eye = front & (V[:, 1] > V[eye_lm, 1].min() - 0.08 * es) \
            & (V[:, 1] < V[eye_lm, 1].max() + 0.09 * es) & (V[:, 2] > self.P("3.7")[2] - 0.5)
        x0 = self.P("3.5")[0]
        up, lo = self.slab(eye, x0)
        self.set("3.1", self.lowest(up), "middle of the upper lid margin: the lowest vertex (ties: "
                 "front-most) of the upper lid in the slab through the pupil 3.5")
        self.set("3.3", self.highest(lo), "middle of the lower lid margin: the highest vertex (ties: "
                 "front-most) of the lower lid in the slab through the pupil 3.5")
        blink = np.linalg.norm(E["eyeBlink_L"], axis=1)
        moving = up[blink[up] >= 0.5 * blink[self.ids["3.1"]]]
        self.set("3.13", moving[np.argmax(V[moving, 1])],
                 "upper outer lid (the top of the moving lid, about the lid crease): the highest "
                 "upper-lid vertex of the slab through 3.5 that moves at least half as much as "
                 "3.1 under eyeBlink_L")
        rise = self.P("3.13")[1] - self.P("3.1")[1]
        slab = np.flatnonzero(front & (np.abs(V[:, 0] - x0) < 0.015 * es) & (V[:, 1] < self.P("3.3")[1])
                              & (V[:, 2] > self.P("3.3")[2] - 0.3) & (self.N[:, 2] > 0.3))
        self.set("3.9", slab[np.argmin(np.abs(V[slab, 1] - (self.P("3.3")[1] - rise)))],
                 "lower outer lid: the front-facing vertex of the slab through 3.5 below 3.3 by "
                 "the height of 3.13 above 3.1")

        # cheeks
        lo_y, hi_y = self.P("9.3")[1], self.P("3.7")[1] - (self.P("3.1")[1] - self.P("3.3")[1])
        c = np.flatnonzero(front & (V[:, 1] > lo_y) & (V[:, 1] < hi_y) & (V[:, 0] > x0))
        u = np.array([np.sin(np.radians(45)), 0.0, np.cos(np.radians(45))])
        self.set("5.3", c[np.argmax(V[c] @ u)],
                 "left cheek bone: the vertex furthest in the direction 45 degrees between +x and "
                 "+z (the zygomatic prominence), among front vertices lateral of the pupil, "
                 "between the height of the nose tip 9.3 and one eye opening below the outer eye "
                 "corner 3.7")
        p = 0.5 * (self.P("8.3") + self.P("5.3"))
        self.set("5.1", self.front_vertex(p[0], p[1]),
                 "centre of the left cheek: front vertex halfway (in x and y) between the lip "
                 "corner 8.3 and the cheek bone 5.3")

        # chin and jaw
        mid = np.flatnonzero(front & (V[:, 0] == 0))
        y21, y82 = self.P("2.1")[1], self.P("8.2")[1]
        c = mid[(V[mid, 1] >= y21) & (V[mid, 1] <= 0.5 * (y21 + y82))]
        d = self.P("2.1")[1:] - self.P("8.2")[1:]
        normal = np.array([-d[1], d[0]]) / np.linalg.norm(d)           # in (y, z)
        normal *= np.sign(normal[1])                                   # anterior
        self.set("2.10", c[np.argmax((V[c][:, 1:] - self.P("8.2")[1:]) @ normal)],
                 "chin boss: on the midline, in the lower half between 2.1 and 8.2, the vertex "
                 "furthest in front of the line from 8.2 to 2.1")
        skin = np.zeros(len(V), dtype=bool)
        skin[self.mesh_ids("Skin")] = True
        c = np.flatnonzero(skin & (V[:, 0] > 0) & (self.N[:, 1] < -0.5) & (self.N[:, 2] > -0.5)
                           & (V[:, 1] > y21 - 0.25 * es) & (V[:, 1] < self.P("8.3")[1]))
        self.set("2.13", c[np.argmin(V[c, 2])],
                 "left corner of the jaw bone (gonion): the rearmost (smallest z) Skin vertex "
                 "with x > 0 of the underside of the jaw (normal pointing down by more than 30 "
                 "degrees, not backwards), between the lip corner height and 0.25 ES0 below 2.1")

        # forehead top ("hairline"; the head is bald): top of the face range
        self.set("11.1", mid[np.argmax(V[mid, 1])],
                 "hairline middle (the head has no hair): the highest midline vertex of the ICT "
                 "face range, the top of its forehead area")
        c = np.flatnonzero(front & (np.abs(V[:, 0] - self.P("4.5")[0]) < 0.04 * es)
                           & (self.N[:, 2] > 0))
        self.set("11.3", c[np.argmax(V[c, 1])],
                 "hairline left: the highest front-facing vertex of the ICT face range above "
                 "the outer end of the left brow 4.5 (|x - x4.5| < 0.04 ES0)")

        # teeth: central incisors at the midline, left side
        for up_fp, lo_fp, mesh in (("9.8", "9.10", "UpperTeeth"), ("9.11", "9.9", "LowerTeeth")):
            t = self.mesh_ids(mesh)
            inc = t[(V[t, 0] >= 0) & (V[t, 0] < 0.03 * es)]
            self.set(up_fp, self.highest(inc),
                     f"top of the {'upper' if mesh == 'UpperTeeth' else 'lower'} teeth: the highest "
                     f"{mesh} vertex within 0.03 ES0 left of the midline (left central incisor)")
            self.set(lo_fp, self.lowest(inc),
                     f"bottom of the {'upper' if mesh == 'UpperTeeth' else 'lower'} teeth: the lowest "
                     f"{mesh} vertex within 0.03 ES0 left of the midline")

        # tongue tip: GumsTongue is one surface (tongue, palate, gums)
        g = self.mesh_ids("GumsTongue")
        gm = g[V[g, 0] == 0]
        sub = self.A_all[gm][:, gm].tocoo()
        ahead = np.full(len(gm), -np.inf)
        np.maximum.at(ahead, sub.row, V[gm[sub.col], 2])
        y_mid = 0.5 * (self.P("9.11")[1] + self.P("9.9")[1])
        peaks = gm[(V[gm, 2] > ahead) & (V[gm, 2] > V[g, 2].mean()) & (V[gm, 1] > y_mid)
                   & (V[gm, 1] < self.P("9.10")[1])]
        self.set("6.1", peaks[np.argmin(V[peaks, 2])],
                 "tip of the tongue: of the forward bulges of the GumsTongue midline (vertices in "
                 "front of their midline mesh neighbours) in its front half, between the heights "
                 "of the middle of the lower incisors and of 9.10, the rearmost one (the other "
                 "is the lower gum, in front of it)")

        for left, right in PAIRS:
            if right not in self.ids:
                self.mirror(left, right)
        return self.ids


def check(data: IctData, ids: dict) -> list:
    """Problems with ``ids`` (empty when none): mirror pairs, the midline, lips, lids."""
    V, E = data.neutral, data.expressions
    out = []
    for left, right in PAIRS:
        d = np.linalg.norm(V[ids[left]] - V[ids[right]] * [-1, 1, 1])
        if d > MIRROR_TOL:
            out.append(f"{left}/{right} don't mirror ({d:.4f} cm)")
        if V[ids[left], 0] <= 0:
            out.append(f"{left} is not on the left (x = {V[ids[left], 0]:.3f})")
    for fp in MIDLINE:
        tol = 0.25 if fp in ("9.8", "9.9", "9.10", "9.11") else 0.05   # incisors: beside it
        if fp in ids and abs(V[ids[fp], 0]) > tol:
            out.append(f"{fp} is off the midline (x = {V[ids[fp], 0]:.3f})")
    jaw = E["jawOpen"][:, 1]
    for fp in ("2.2", "2.6", "2.7"):
        if not jaw[ids[fp]] > -1.0:
            out.append(f"{fp} (upper inner lip) moves down {-jaw[ids[fp]]:.2f} under jawOpen")
    for fp in ("2.3", "2.8", "2.9"):
        if not jaw[ids[fp]] < -2.0:
            out.append(f"{fp} (lower inner lip) moves down only {-jaw[ids[fp]]:.2f} under jawOpen")
    for fp, ex, big in (("3.1", "eyeBlink_L", True), ("3.2", "eyeBlink_R", True),
                        ("3.3", "eyeBlink_L", False), ("3.4", "eyeBlink_R", False)):
        dy = -E[ex][ids[fp], 1]
        if (dy > 0.5) != big:
            out.append(f"{fp} moves down {dy:.2f} under {ex}")
    return out


def write_json(data: IctData, picker: Picker, path: Path) -> None:
    layout = picker.layout
    order = point_order(picker.ids)
    doc = {
        "format": "mpeg4fba-ict-feature-point-ids",
        "version": 1,
        "description": ("MPEG-4 feature point -> vertex id of the ICT-FaceKit generic neutral "
                        "(ict_facekit_light.npz, 26,719 vertices; cm, y up, +z toward the "
                        "viewer, left = +x). Our choice, derived by benchmarks/ict_pick_points.py "
                        "with the rule given for each point; 7.1 is not a vertex (see "
                        "benchmarks.ict.spine_top). 6.1 lies on GumsTongue (tongue, palate and "
                        "gums in one surface) and is left out of ict_face() by default."),
        "data": {"file": "data/ict-facekit/ict_facekit_light.npz",
                 "source_commit": data.source_commit},
        "points": {fp: picker.ids[fp] for fp in order},
        "meshes": {fp: layout.locate(picker.ids[fp])[0][0] for fp in order},
        "rules": {fp: picker.rules[fp] for fp in order},
        "computed": {"7.1": " ".join((spine_top.__doc__ or "").split("``ids``")[0].split())},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


# -- the picture --------------------------------------------------------------------------------
def _draw(ax, parts: list, axes: tuple, view: np.ndarray, light, cull: bool = True) -> None:
    """Lambert-shaded triangles of ``parts`` [(vertices, triangles, rgb)] seen along
    ``-view``, drawn back to front (painter's algorithm) on the plane of ``axes``."""
    from matplotlib.collections import PolyCollection
    polys, depth, cols = [], [], []
    light = np.asarray(light, float) / np.linalg.norm(light)
    for V, T, color in parts:
        fn = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
        fn /= np.linalg.norm(fn, axis=1, keepdims=True) + 1e-12
        if cull:
            T, fn = T[fn @ view > 0], fn[fn @ view > 0]
        fn = fn * np.sign(fn @ view + 1e-12)[:, None]          # back faces lit as front
        polys.append(V[T][:, :, list(axes)])
        depth.append((V[T] @ view).mean(axis=1))
        cols.append(np.outer(np.clip(fn @ light, 0, 1) * 0.7 + 0.3, color))
    order = np.argsort(np.concatenate(depth))
    P, C = np.concatenate(polys)[order], np.concatenate(cols)[order]
    ax.add_collection(PolyCollection(P, facecolors=C, edgecolors=C, linewidths=0.1))


def plot(data: IctData, ids: dict, path: Path) -> None:
    """Draw the points ``ids`` (and 7.1) on the head: front, side and close-ups."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    face = ict_face(data, fp_ids=ids, tongue_tip=True)
    pts = face.points
    fig = plt.figure(figsize=(26, 22))
    panels = [
        ("front", fig.add_axes([0.02, 0.36, 0.46, 0.62]), (0, 1), [0, 0, 1.0], None),
        ("left side (from +x)", fig.add_axes([0.50, 0.36, 0.48, 0.62]), (2, 1), [1.0, 0, 0], None),
        ("mouth, front", fig.add_axes([0.02, 0.02, 0.31, 0.32]), (0, 1), [0, 0, 1.0],
         (-3.2, 3.2, -5.0, -0.3)),
        ("left eye, front", fig.add_axes([0.35, 0.02, 0.30, 0.32]), (0, 1), [0, 0, 1.0],
         (1.3, 5.2, 2.3, 5.0)),
        ("midline: mouth, teeth, tongue (from +x, the half x >= 0 removed)", fig.add_axes([0.67, 0.02, 0.31, 0.32]),
         (2, 1), [1.0, 0, 0], (8.5, 13.3, -6.5, 1.0)),
    ]
    colors = {"Skin": (0.92, 0.76, 0.66), "LeftEyeball": (0.95, 0.95, 0.95),
              "RightEyeball": (0.95, 0.95, 0.95), "UpperTeeth": (1.0, 1.0, 0.85),
              "LowerTeeth": (1.0, 1.0, 0.85), "GumsTongue": (0.85, 0.45, 0.45)}
    for title, ax, axes, view, lim in panels:
        view = np.asarray(view)
        parts = []
        for name, col in colors.items():
            m = face.meshes[name]
            T = m.triangles
            if title.startswith("midline"):
                T = T[(m.vertices[T][:, :, 0] < 0).all(axis=1)]
            parts.append((m.vertices, T, col))
        midline = title.startswith("midline")
        _draw(ax, parts, axes, view, view + [0.3, 0.4, 0.2], cull=not midline)
        for fp in pts:
            p = pts[fp]
            if view[0] > 0 and p[0] < -0.5:          # side view: the right side is hidden
                continue
            if midline and abs(p[0]) > 0.3:
                continue
            if lim is not None and not (lim[0] <= p[axes[0]] <= lim[1] and lim[2] <= p[axes[1]] <= lim[3]):
                continue
            ax.plot(p[axes[0]], p[axes[1]], "o", ms=4, color="blue" if fp != "7.1" else "red")
            ax.annotate(fp, (p[axes[0]], p[axes[1]]), xytext=(3, 3), textcoords="offset points",
                        fontsize=9 if lim is None else 11, color="navy")
        ax.set_aspect("equal")
        ax.autoscale_view()
        if lim is not None:
            ax.set_xlim(lim[0], lim[1])
            ax.set_ylim(lim[2], lim[3])
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
    fig.savefig(path, dpi=70)
    plt.close(fig)


def main(argv: Optional[list] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shared", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--out", type=Path, default=FP_JSON, help="JSON to write")
    ap.add_argument("--plot", type=Path, default=None, help="PNG picture of the points")
    ap.add_argument("--check", action="store_true", help="only compare with the JSON")
    args = ap.parse_args(argv)
    data = load_ict(args.shared)
    picker = Picker(data)
    ids = picker.pick()
    problems = check(data, ids)
    for p in problems:
        print("PROBLEM:", p)
    if args.check:
        with open(args.out, encoding="utf-8") as f:
            stored = {k: int(v) for k, v in json.load(f)["points"].items()}
        diff = sorted(set(stored.items()) ^ set(ids.items()))
        print("same as", args.out if not diff else f"DIFFERENT from {args.out}: {diff}")
        return int(bool(diff or problems))
    if problems:
        return 1
    write_json(data, picker, args.out)
    print(f"wrote {len(ids)} points to {args.out}")
    if args.plot:
        plot(data, ids, args.plot)
        print(f"drew {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
