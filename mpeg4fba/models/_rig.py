"""The reference head's rig: a FaceDefTable for each low-level FAP (3-68).

Skin FAPs are FaceDefMesh entries: a weight per vertex (1 at the FAP's feature point,
falling smoothly to 0) times the FAP's axis times its FAPU unit, so the feature point
moves exactly as the standard says and its surroundings follow.  The weights are
products of smooth profiles in the coordinates the skin builder gave each vertex:

* lips: along the mouth, ``c = cos(phi)`` of the column, with raised-cosine "hats" at
  the feature points' columns (c = -1, -0.5, 0, 0.5, 1) that add up to 1, so moving
  all of a lip's points together moves the whole lip; across, the ring parameter
  ``t`` (inner FAPs own the inner half of the lip and the tuck, outer FAPs the outer
  half and the skin beyond, their weights adding up to 1 across the lip); and the
  side: upper-lip FAPs have weight 0 on every lower-lip vertex and vice versa;
* eyelids: the opening's profile along the lid (so that top + bottom = 1024 closes
  the eye at every column) times the ring (margin and tuck 1, fading to 0 at the
  crease); lid vertices slide round the eyeball on their own sphere;
* brows: hats along the brow through 4.1, 4.3, 4.5 (adding up to 1) times a fall-off
  across it; cheeks, nose, chin: raised-cosine fall-off of the distance; jaw: a region
  under the lower lip and along the jawline, less on the throat; ears: how far the
  ear stands off the head.

Jaw, eyeball and head motion are FaceDefTransforms of the Jaw, LeftEye / RightEye and
Head Transforms; tongue and pupil FAPs deform the Tongue and eyeball meshes.

>>> c = np.linspace(-1, 1, 9)
>>> hat(c, 0.0)[3:6].round(3).tolist()              # a hat round the middle column
[0.5, 1.0, 0.5]
>>> bool(np.allclose(sum(hat(c, k) for k in (-1, -0.5, 0, 0.5, 1)), 1.0))   # they add up to 1
True
>>> raised_cosine(np.array([0.0, 5.0, 10.0, 20.0]), 10.0).tolist()
[1.0, 0.5, 0.0, 0.0]
"""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np

from ..fba.fapu import FAPU
from ..fba.fat import FaceDefMesh, FaceDefTable, FaceDefTransform
from ..fba.tables import FAP
from ._shape import Design, smoothstep
from ._skin import PATCH_LEFT_EYE, PATCH_MOUTH, PATCH_RIGHT_EYE, Skin

__all__ = ["low_level_tables", "hat", "raised_cosine"]

S = smoothstep


def raised_cosine(dist: np.ndarray, radius: float) -> np.ndarray:
    """1 at distance 0, falling smoothly to 0 at ``radius``: (1 + cos(pi d / r)) / 2."""
    u = np.clip(dist / radius, 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * u))


def hat(c: np.ndarray, node: float, half: float = 0.5) -> np.ndarray:
    """cos^2 hat of half-width ``half`` at ``node``; hats at nodes ``half`` apart sum to 1."""
    u = np.clip(np.abs(c - node) / half, 0.0, 1.0)
    return np.cos(np.pi / 2 * u) ** 2


def _borders(fap: int) -> np.ndarray:
    lo, hi = FAP[fap].range
    return np.array([0.0, hi]) if FAP[fap].unidirectional else np.array([lo, 0.0, hi])


def _mesh_entry(mesh: str, fap: int, weights: np.ndarray, vector: np.ndarray,
                fp_index: Optional[int] = None, min_weight: float = 1e-4) -> FaceDefMesh:
    """Per-unit displacement ``weights * vector`` (vector [3] or [n, 3]) on the vertices
    with a weight, the same on both sides of 0; the feature point's is exact."""
    vector = np.asarray(vector, float)
    idx = np.flatnonzero(weights > min_weight)
    vec = vector[idx] if vector.ndim == 2 else np.broadcast_to(vector, (len(idx), 3))
    disp = weights[idx, None] * vec
    if fp_index is not None:
        k = np.searchsorted(idx, fp_index)
        if k >= len(idx) or idx[k] != fp_index:
            raise AssertionError(f"FAP {fap}: its feature point vertex has no weight")
        disp[k] = vector if vector.ndim == 1 else vector[fp_index]
    borders = _borders(fap)
    n_int = len(borders) - 1
    return FaceDefMesh(mesh, borders, idx, np.repeat(disp[:, None, :], n_int, axis=1))


def _path_entry(mesh: str, borders: np.ndarray, idx: np.ndarray,
                position: Callable[[float], np.ndarray]) -> FaceDefMesh:
    """A FaceDefMesh following positions ``position(value)`` [len(idx), 3] through the
    borders: each interval holds the secant between its ends, per unit."""
    at = np.stack([position(b) for b in borders])                   # [borders, n, 3]
    per_unit = np.diff(at, axis=0) / np.diff(borders)[:, None, None]
    return FaceDefMesh(mesh, borders, idx, per_unit.transpose(1, 0, 2))


def low_level_tables(d: Design, skin: Skin, points: dict, fapu: FAPU, parts: dict,
                     names: dict) -> list:
    """FaceDefTables for FAPs 3-68 (millimetres per FAP unit).

    ``points`` are feature point positions in the face frame, ``parts`` the other
    meshes' :class:`~._parts.Part` (keys "eye", "tongue"), ``names`` the mesh and
    Transform names, ``skin.points`` and the parts' points the feature point vertices.
    """
    V, fp = skin.vertices, skin.points
    x, y, z = V.T
    patch, c, t, side = skin.patch, skin.c, skin.t, skin.side
    mouth = patch == PATCH_MOUTH
    unit = {n: fapu.unit(n) for n in range(3, 69)}
    tables: dict = {n: FaceDefTable(n) for n in range(3, 69)}
    SK = names["skin"]

    def add(n: int, weights: np.ndarray, fp_id: str, vector=None) -> None:
        vec = np.asarray(FAP[n].axis, float) * unit[n] if vector is None else vector
        tables[n].meshes.append(_mesh_entry(SK, n, weights, vec, fp[fp_id]))

    # -- lips ----------------------------------------------------------------------------
    t_m = np.where(mouth, t, np.inf)
    a_in = np.where(t_m <= 0, 1.0, 1.0 - S(t_m))
    a_out = np.where(t_m <= 1, S(t_m), 1.0 - S((t_m - 1) / 0.75))
    a_corner = np.where(t_m <= 1, S(t_m), 1.0 - S((t_m - 1) / 0.98))
    a_push = np.where(t_m <= 1, 1.0, 1.0 - S((t_m - 1) / 0.75))
    upper = mouth & (side > 0)
    lower = mouth & (side < 0)
    inner = {4: (0.0, upper, "2.2"), 8: (0.5, upper, "2.6"), 9: (-0.5, upper, "2.7"),
             5: (0.0, lower, "2.3"), 10: (0.5, lower, "2.8"), 11: (-0.5, lower, "2.9")}
    for n, (node, where, fp_id) in inner.items():
        add(n, hat(c, node) * a_in * where, fp_id)
    outer = {51: (0.0, upper, "8.1"), 55: (0.5, upper, "8.5"), 56: (-0.5, upper, "8.6"),
             52: (0.0, lower, "8.2"), 57: (0.5, lower, "8.7"), 58: (-0.5, lower, "8.8")}
    for n, (node, where, fp_id) in outer.items():
        add(n, hat(c, node) * a_out * where, fp_id)
    for n, node, fp_id in ((6, 1.0, "2.4"), (12, 1.0, "2.4"), (7, -1.0, "2.5"), (13, -1.0, "2.5")):
        add(n, hat(c, node) * a_in * mouth, fp_id)
    for n, node, fp_id in ((53, 1.0, "8.3"), (59, 1.0, "8.3"), (54, -1.0, "8.4"), (60, -1.0, "8.4")):
        add(n, hat(c, node) * a_corner * mouth, fp_id)
    along = np.cos(np.pi / 2 * np.clip(c, -1, 1)) ** 2
    add(16, along * a_push * lower, "2.3")
    add(17, along * a_push * upper, "2.2")
    # -- jaw and chin --------------------------------------------------------------------
    ax = np.abs(x)
    top = np.interp(ax, [0, 22, 35, 48, 70], [d.lip_y - 9, d.lip_y - 10, d.lip_y - 14, -84, -88])
    jaw = S((top - y) / 12.0)
    throat = 1.0 - (1.0 - S((z - 25.0) / 35.0)) * S((-100.0 - y) / 14.0)
    jaw *= throat * S((z + 15.0) / 25.0)
    in_lip = np.where(t_m <= 1, 0.0, 1.0 - np.where(side < 0, a_out, a_corner))
    jaw = np.where(mouth, jaw * in_lip * (side <= 0), jaw)
    jaw[fp["2.1"]] = 1.0
    add(3, jaw, "2.1")
    add(14, jaw, "2.1")
    add(15, jaw, "2.1")
    chin = raised_cosine(np.linalg.norm(V - points["2.10"], axis=1), 17.0) * S((d.lip_y - 12 - y) / 6)
    chin = np.where(mouth, chin * (side < 0), chin)
    add(18, chin, "2.10")
    hinge = d.hinge
    lever = points["9.11"][2] - hinge[2]                 # lower incisors from the hinge
    tables[3].transforms.append(FaceDefTransform(names["jaw"], "rotation",
                                                 rotation=(1.0, 0.0, 0.0, unit[3] / lever)))
    tables[14].transforms.append(FaceDefTransform(names["jaw"], "translation",
                                                  translation=tuple(np.array(FAP[14].axis) * unit[14])))
    tables[15].transforms.append(FaceDefTransform(names["jaw"], "translation",
                                                  translation=tuple(np.array(FAP[15].axis) * unit[15])))
    # -- eyelids ---------------------------------------------------------------------------
    for sgn, kind, ids in ((1, PATCH_LEFT_EYE, (19, 21, "3.1", "3.3")),
                           (-1, PATCH_RIGHT_EYE, (20, 22, "3.2", "3.4"))):
        centre = d.eye_centre(sgn)
        eye = patch == kind
        s_phi = np.sqrt(np.clip(1 - c * c, 0, 1))
        profile = 0.5 * (s_phi ** 0.62 + s_phi ** 0.75)          # (upper + lower) / 2
        row = np.where(t <= 0, 1.0, 1.0 - S(t / 0.95))
        for n, lid_side, fp_id in ((ids[0], 1, ids[2]), (ids[1], -1, ids[3])):
            w = np.where(eye & (side == lid_side), profile * row, 0.0)
            w[fp[fp_id]] = 1.0
            idx = np.flatnonzero(w > 1e-4)
            p0 = V[idx]
            dy = -lid_side * unit[n] * w[idx]                    # per unit, along y
            rad = np.linalg.norm(p0 - centre, axis=1)
            slide = (t[idx] != 0) & (t[idx] < 1)                 # the margin moves straight

            def position(value, p0=p0, dy=dy, rad=rad, slide=slide, centre=centre):
                p = p0.copy()
                p[:, 1] += dy * value
                dx2 = (p0[:, 0] - centre[0]) ** 2
                z0 = np.sqrt(np.maximum(rad ** 2 - dx2 - (p0[:, 1] - centre[1]) ** 2, 0))
                z1 = np.sqrt(np.maximum(rad ** 2 - dx2 - (p[:, 1] - centre[1]) ** 2, 0))
                p[:, 2] += np.where(slide, z1 - z0, 0.0)
                return p

            lo, hi = FAP[n].range
            borders = np.array([lo, lo / 2, 0, hi / 4, hi / 2, 3 * hi / 4, hi])
            entry = _path_entry(SK, borders, idx, position)
            k = np.searchsorted(idx, fp[fp_id])
            entry.displacements[k] = np.array(FAP[n].axis) * unit[n]
            tables[n].meshes.append(entry)
    # -- brows -----------------------------------------------------------------------------
    for sgn, ids, faps in ((1, ("4.1", "4.3", "4.5"), (31, 33, 35, 37)),
                           (-1, ("4.2", "4.4", "4.6"), (32, 34, 36, 38))):
        p_in, p_mid, p_out = (points[k] for k in ids)
        xs = np.array([p_in[0], p_mid[0], p_out[0]]) * sgn
        ys = np.array([p_in[1], p_mid[1], p_out[1]])
        curve = np.polyfit(xs, ys, 2)
        u = x * sgn
        v = y - np.polyval(curve, np.clip(u, xs[0] - 10, xs[2] + 10))
        across = np.where(v >= 0, 1.0 - S(v / 30.0), 1.0 - S(-v / 11.0))
        eye_rows = np.where((patch == PATCH_LEFT_EYE) | (patch == PATCH_RIGHT_EYE),
                            S((t - 0.8) / 0.7), 1.0)
        across = across * eye_rows * (u > 0)
        b = (u - xs[0]) / (xs[2] - xs[0])
        bm = (xs[1] - xs[0]) / (xs[2] - xs[0])
        w_in = np.where(b < 0, np.cos(np.pi / 2 * np.clip(-b * (xs[2] - xs[0]) / 13.0, 0, 1)) ** 2,
                        np.cos(np.pi / 2 * np.clip(b / bm, 0, 1)) ** 2)
        w_mid = np.where(b < bm, np.sin(np.pi / 2 * np.clip(b / bm, 0, 1)) ** 2,
                         np.cos(np.pi / 2 * np.clip((b - bm) / (1 - bm), 0, 1)) ** 2)
        w_out = np.where(b <= 1, np.sin(np.pi / 2 * np.clip((b - bm) / (1 - bm), 0, 1)) ** 2,
                         np.cos(np.pi / 2 * np.clip((b - 1) * (xs[2] - xs[0]) / 15.0, 0, 1)) ** 2)
        add(faps[0], w_in * across, ids[0])
        add(faps[1], w_mid * across, ids[1])
        add(faps[2], w_out * across, ids[2])
        add(faps[3], (w_in + 0.5 * w_mid) * across, ids[0])
    # -- cheeks, nose, ears ------------------------------------------------------------------
    not_lips = np.where(mouth, S((t - 1.2) / 0.5), 1.0)
    not_lids = np.where((patch == PATCH_LEFT_EYE) | (patch == PATCH_RIGHT_EYE), S((t - 0.3) / 0.6), 1.0)
    for sgn, (puff, lift, stretch, raise_ear, pull_ear), (c1, c3, n1, e1, e3) in (
            (1, (39, 41, 61, 65, 67), ("5.1", "5.3", "9.1", "10.1", "10.3")),
            (-1, (40, 42, 62, 66, 68), ("5.2", "5.4", "9.2", "10.2", "10.4"))):
        this_side = S((sgn * x - 1.0) / 5.0)
        dist = lambda k: np.linalg.norm(V - points[k], axis=1)           # noqa: E731
        add(puff, raised_cosine(dist(c1), 26.0) * this_side * not_lips * not_lids, c1)
        add(lift, raised_cosine(dist(c3), 24.0) * this_side * not_lips * not_lids, c3)
        add(stretch, raised_cosine(dist(n1), 10.0) * this_side * (patch != PATCH_MOUTH), n1)
        ear = S((skin.ear - 0.5) / 2.5) * (sgn * x > 0)
        add(raise_ear, ear, e1)
        add(pull_ear, ear, e3)
    tip = np.linalg.norm(V - points["9.3"], axis=1)
    add(63, raised_cosine(tip, 15.0) * (patch != PATCH_MOUTH), "9.3")
    add(64, raised_cosine(tip, 19.0) * (patch != PATCH_MOUTH), "9.3")
    # -- transforms: eyeballs, head -------------------------------------------------------------
    for n, tr in ((23, "left_eye"), (25, "left_eye"), (24, "right_eye"), (26, "right_eye"),
                  (48, "head"), (49, "head"), (50, "head")):
        tables[n].transforms.append(FaceDefTransform(names[tr], "rotation",
                                                     rotation=tuple(FAP[n].axis) + (1e-5,)))
    for n, tr in ((27, "left_eye"), (28, "right_eye")):
        tables[n].transforms.append(FaceDefTransform(
            names[tr], "translation", translation=tuple(np.array(FAP[n].axis) * unit[n])))
    # -- pupils: the pupil's border moves out (diameter + value x IRISD) ---------------------
    dil = parts["eye"].info["dilate"]
    idx = np.flatnonzero(np.linalg.norm(dil, axis=1) > 1e-9)
    shrink = min(1.0, 0.6 * d.pupil_r / (abs(FAP[29].range[0]) * unit[29] / 2))
    for n, mesh in ((29, names["left_eyeball"]), (30, names["right_eyeball"])):
        per_unit = dil[idx] * unit[n] / 2
        lo, hi = FAP[n].range
        tables[n].meshes.append(FaceDefMesh(mesh, [lo, 0, hi], idx,
                                            np.stack([per_unit * shrink, per_unit], axis=1)))
    # -- tongue --------------------------------------------------------------------------------
    tv = parts["tongue"].vertices
    tp = parts["tongue"].points
    TG = names["tongue"]
    length = tv[:, 2].max() - tv[:, 2].min()
    tip_w = np.cos(np.pi / 2 * np.clip((tv[tp["6.1"], 2] - tv[:, 2]) / (0.7 * length), 0, 1)) ** 2
    for n in (43, 44, 45):
        tables[n].meshes.append(_mesh_entry(TG, n, tip_w, np.array(FAP[n].axis) * unit[n], tp["6.1"]))
    body = raised_cosine(np.abs(tv[:, 2] - tv[tp["6.2"], 2]), 0.6 * length)
    tables[46].meshes.append(_mesh_entry(TG, 46, body, np.array(FAP[46].axis) * unit[46], tp["6.2"]))
    curl = np.column_stack([np.zeros(len(tv)), np.abs(tv[:, 0]) * unit[47], np.zeros(len(tv))])
    tables[47].meshes.append(_mesh_entry(TG, 47, np.ones(len(tv)), curl))
    # -- what moves the skin under the hair moves the hair -----------------------------------
    over = parts["hair_over"]                     # hair vertex k lies over skin vertex over[k]
    where = np.full(len(V), -1)
    where[over] = np.arange(len(over))
    for table in tables.values():
        for m in list(table.meshes):
            if m.mesh != SK:
                continue
            hit = where[m.indices] >= 0
            if hit.any():
                table.meshes.append(FaceDefMesh(names["hair"], m.borders, where[m.indices[hit]],
                                                m.displacements[hit]))
    return [tables[n] for n in range(3, 69)]
