"""The reference head's skin: one triangle mesh with a mouth slit and two eye holes.

How it is made (all numpy, no loop over vertices):

* **Patches** round the mouth and each eye are structured: closed rings of 2N vertices
  each, ring after ring from the hole outward, column ``j`` at angle ``phi = pi j / N``
  about the patch centre (0 at the face's left end, upper half first).  The mouth's
  innermost rings tuck back into the mouth; then comes the inner lip contour, a ring
  whose upper and lower halves touch (the slit: ``j`` and ``2N - j`` are distinct
  vertices at one place, and no triangle joins them), the vermilion, the outer lip
  contour and skin.  The eye's tuck rings reach back to the eyeball; then come the lid
  margin (an almond tangent to the iris), the lids, the crease and skin.  Each vertex
  knows its patch, its column's ``c = cos(phi)``, its ring's ``t`` (0 at the inner
  contour or margin, 1 at the outer contour or crease, negative in the tuck) and its
  side (+1 upper, -1 lower, 0 the corner columns).
* **Feature points** outside the patches are placed where the standard puts them (the
  nose tip is the foremost point of the nose, the top of the skull the highest...),
  found on the surface by small searches.
* **Background** points are a sunflower spiral of directions from the ray origin,
  denser on the face, jittered by the seed; those under a patch or too near a feature
  point are dropped.  The convex hull of all the directions is their spherical
  Delaunay triangulation; its triangles inside a patch are replaced by the patch's.

The background, the landmarks and the patches' outer rings lie on
:class:`~._shape.HeadSurface` (cast along their directions), and a patch's outer ring is
shared with the background triangulation, so the seams are exact.

>>> phi, c, s, side = _ring_columns(6)               # columns of a patch, 6 per half
>>> c.round(2).tolist()
[1.0, 0.87, 0.5, 0.0, -0.5, -0.87, -1.0, -0.87, -0.5, 0.0, 0.5, 0.87]
>>> side.tolist()                                    # corner, upper half, corner, lower
[0, 1, 1, 1, 1, 1, 0, -1, -1, -1, -1, -1]
>>> _inside(np.array([[0, 0], [2, 0], [2, 2], [0, 2]]), np.array([[1, 1], [3, 1]])).tolist()
[True, False]
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from ._shape import Design, HeadSurface, raycast, smoothstep, surface_at_xy

__all__ = ["Skin", "build_skin", "PATCH_MOUTH", "PATCH_LEFT_EYE", "PATCH_RIGHT_EYE"]

PATCH_MOUTH, PATCH_LEFT_EYE, PATCH_RIGHT_EYE = 1, 2, 3


@dataclass
class Skin:
    """The skin mesh and what the rig needs to know about its vertices (mm)."""

    vertices: np.ndarray
    triangles: np.ndarray
    points: dict                       # feature point id -> vertex index
    patch: np.ndarray                  # 0, PATCH_MOUTH, PATCH_LEFT_EYE, PATCH_RIGHT_EYE
    c: np.ndarray                      # cos(phi) of the column (patch vertices)
    t: np.ndarray                      # ring parameter (patch vertices)
    side: np.ndarray                   # +1 upper, -1 lower, 0 corner column
    ear: np.ndarray                    # how far the ear stands off the head (mm)
    extras: dict = field(default_factory=dict)


# -- patches ------------------------------------------------------------------------------
@dataclass
class _Patch:
    kind: int
    n: int                             # columns per half
    xyz: np.ndarray                    # [rings, 2N, 3]
    t: np.ndarray                      # [rings]
    outline: np.ndarray                # [2N, 2] face-plane outline of the outer ring

    @property
    def phi(self) -> np.ndarray:
        return np.pi * np.arange(2 * self.n) / self.n

    def triangles(self, first: int) -> np.ndarray:
        """Quads between consecutive rings, two triangles each, wound outward."""
        R, C = self.xyz.shape[:2]
        r, j = np.meshgrid(np.arange(R - 1), np.arange(C), indexing="ij")
        a = first + r * C + j
        b = first + r * C + (j + 1) % C
        a2, b2 = a + C, b + C
        t1 = np.stack([a, a2, b2], axis=-1).reshape(-1, 3)
        t2 = np.stack([a, b2, b], axis=-1).reshape(-1, 3)
        return np.concatenate([t1, t2])


def _ring_columns(n: int) -> tuple:
    phi = np.pi * np.arange(2 * n) / n
    c = np.cos(phi)
    s = np.sin(phi)
    c[np.isclose(c, 0.0, atol=1e-12)] = 0.0
    side = np.where(s > 1e-9, 1, np.where(s < -1e-9, -1, 0))
    return phi, c, s, side


def _patch_rings(F: HeadSurface, inner: np.ndarray, mid: np.ndarray, edge: np.ndarray,
                 n_in: int, n_skin: int, power: float) -> tuple:
    """(P (rings, columns, 3) on the head surface with x, y exactly on the designed
    contours, ring parameters ``ts``): ``n_in + 2`` rings from ``inner`` to ``mid``
    (t 0..1), then ``n_skin`` rings from ``mid`` out to ``edge`` (t 1..2, denser near
    ``mid`` by ``power``)."""
    t_in = np.linspace(0, 1, n_in + 2)
    t_skin = 1 + (np.arange(1, n_skin + 1) / n_skin) ** power
    rings_xy = [inner + tv * (mid - inner) for tv in t_in]
    rings_xy += [mid + (ts - 1) * (edge - mid) for ts in t_skin]
    ts = np.concatenate([t_in, t_skin])
    P = surface_at_xy(F, np.concatenate(rings_xy)).reshape(len(ts), len(inner), 3)
    P[..., :2] = np.asarray(rings_xy)
    return P, ts


def _mouth_patch(F: HeadSurface, d: Design, res: float) -> _Patch:
    n = 12 * max(1, int(round(2 * res)))                   # columns per lip; 7.5 deg at res 1
    phi, c, s, side = _ring_columns(n)
    up = side > 0
    ac = np.abs(c)
    # inner contour: the slit (lips touching), corners shared
    gap = d.lip_gap / 2 * np.abs(s)
    inner = np.column_stack([d.mouth_inner * c, d.lip_y + side * gap])
    # outer contour: the vermilion border with a Cupid's bow on the upper lip
    bow = np.exp(-((ac - np.cos(np.radians(75))) / 0.13) ** 2)
    h_up = (d.upper_lip_h + (d.upper_lip_peak - d.upper_lip_h) * bow * 1.6) * (1 - c * c) ** 0.55
    h_lo = d.lower_lip_h * (1 - c * c) ** 0.6
    outer = np.column_stack([d.mouth_outer * c, d.lip_y + np.where(up, h_up, -h_lo)])
    # boundary: an ellipse round the mouth, under the nose and above the chin
    ax_e = d.mouth_outer + 21.0
    edge = np.column_stack([ax_e * c, d.lip_y + 1.0 + np.where(up, 18.0, 23.0) * s])
    n_verm = max(2, int(round(3 * res)))
    n_skin = max(3, int(round(5 * res)))
    P, ts = _patch_rings(F, inner, outer, edge, n_verm, n_skin, 1.25)
    # lips: thickness along z, by ring and column
    T = ts[:, None]
    g = (1 - c * c)[None, :] ** 0.4
    meet = 0.55
    upper = np.where(T <= 1, meet + (1 - meet) * np.sin(np.pi / 2 * np.clip(T, 0, 1)) ** 0.8,
                     1 - smoothstep((T - 1) / (ts[-1] - 1) * 1.15))
    lower_in = meet * 3.4 / 4.3 + (1 - meet * 3.4 / 4.3) * np.sin(np.pi * np.clip(T, 0, 1) * 0.62) ** 0.9
    u = np.clip((T - 1) / (ts[-1] - 1), 0, 1)
    lower = np.where(T <= 1, lower_in * (1 - 0.25 * smoothstep((T - 0.6) / 0.4)),
                     0.75 * (1 - smoothstep(u / 0.45)) - 0.45 * np.sin(np.pi * u) * (u > 0.3))
    thick = np.where(up[None, :], 3.4 * upper, 4.3 * lower) * g
    corner = smoothstep((ac - 0.72) / 0.28)[None, :] * (1 - smoothstep((T - 1.0) / 0.8))
    P[..., 2] += thick - 1.8 * corner
    # the tuck: three rings curling back into the mouth, behind the inner contour
    lip_in = P[0]
    gt = (1 - c * c) ** 0.3
    tuck = []
    for k, (dy, dz, dx) in enumerate([(1.1, 2.4, 0.4), (2.6, 5.0, 1.0), (4.0, 7.6, 1.6)]):
        off = np.column_stack([-np.sign(c) * dx * (1 - gt),
                               side * dy * (0.35 + 0.65 * gt),
                               -dz * (0.45 + 0.55 * gt)])
        tuck.append(lip_in + off)
    tuck = np.stack(tuck[::-1])
    xyz = np.concatenate([tuck, P])
    t_all = np.concatenate([[-3.0, -2.0, -1.0], ts])
    return _Patch(PATCH_MOUTH, n, xyz, t_all, edge)


def _eye_patch(F: HeadSurface, d: Design, res: float, sgn: int) -> _Patch:
    n = 2 * max(4, int(round(8 * res)))                    # columns per lid; even: 3.1 on one
    phi, c, s, side = _ring_columns(n)
    up = side > 0
    cx, cy = sgn * d.eye_x, d.eye_y
    centre = d.eye_centre(sgn)
    a = d.iris_r                                           # lids tangent to the iris
    f = np.abs(s) ** np.where(up, 0.62, 0.75)
    tilt = d.canthal_tilt * c * sgn                        # outer corner a little higher
    hw = d.eye_half_width
    margin = np.column_stack([cx + hw * c, cy + side * a * f + tilt])
    crease_h = np.where(up, 1.2 + 5.0 * f, -(1.0 + 4.0 * f))
    crease = np.column_stack([cx + (hw + 2.5) * c, margin[:, 1] + crease_h])
    edge = np.column_stack([cx + (hw + 11.0) * c, cy + 2.0 + np.where(up, 19.0, 16.0) * s])
    n_lid = max(1, int(round(2 * res)))
    n_skin = max(3, int(round(4 * res)))
    P, ts = _patch_rings(F, margin, crease, edge, n_lid, n_skin, 1.2)
    # the margin sits on the lid sphere (clear of the eyeball when the lids close)
    m = P[0]
    dx, dy = m[:, 0] - centre[0], m[:, 1] - centre[1]
    on_sphere = centre[2] + np.sqrt(np.maximum(d.lid_r ** 2 - dx ** 2 - dy ** 2, 0.0))
    P[0, :, 2] = np.maximum(on_sphere, m[:, 2])
    # tuck: back from the margin to just above the eyeball
    v = P[0] - centre
    rad = np.linalg.norm(v, axis=1)
    tuck = [centre + v * ((d.eye_r + 0.35 + (rad - d.eye_r - 0.35) * w) / rad)[:, None]
            for w in (0.0, 0.5)]
    xyz = np.concatenate([np.stack(tuck), P])
    t_all = np.concatenate([[-2.0, -1.0], ts])
    return _Patch(PATCH_LEFT_EYE if sgn > 0 else PATCH_RIGHT_EYE, n, xyz, t_all, edge)


# -- landmarks ----------------------------------------------------------------------------
def _dirs_to(d: Design, P: np.ndarray) -> np.ndarray:
    v = np.atleast_2d(P) - d.origin
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _profile(F: HeadSurface, angles: np.ndarray, x_plane: float = 0.0) -> np.ndarray:
    """Surface points along the midline: rays in the plane x = 0 at ``angles`` (radians
    from +z toward +y)."""
    dirs = np.column_stack([np.zeros_like(angles), np.sin(angles), np.cos(angles)])
    return raycast(F, dirs)


def _landmarks(F: HeadSurface, F_noear: HeadSurface, d: Design) -> dict:
    """Surface points (mm) of the feature points outside the patches."""
    W, J, N = d.W, d.J, d.N
    at = {}
    # nose: the tip is the foremost point of the midline round its design position
    ys = d.nose_tip[1] + np.linspace(-7, 5, 61)
    cand = surface_at_xy(F, np.column_stack([np.zeros_like(ys), ys]))
    at["9.3"] = cand[np.argmax(cand[:, 2])]
    # chin: the boss is its foremost point, the bottom where the profile turns under
    prof = _profile(F, np.radians(np.linspace(-75, -25, 600)))
    zone = np.flatnonzero((prof[:, 1] < -88) & (prof[:, 1] > -112))
    k = zone[np.argmax(prof[zone, 2])]
    at["2.10"] = prof[k]
    tang = np.gradient(prof, axis=0)
    slope = np.degrees(np.arctan2(-tang[:, 1], tang[:, 2]))       # 0 level, 90 straight down
    score = np.abs(slope - 45.0) + 1000.0 * (prof[:, 1] > at["2.10"][1] - 6) + 1000.0 * (np.arange(len(prof)) >= k)
    at["2.1"] = prof[np.argmin(score)]
    # skull: top and back of the midline
    prof = _profile(F, np.radians(np.linspace(30, 200, 700)))
    at["11.4"] = prof[np.argmax(prof[:, 1])]
    at["11.6"] = prof[np.argmin(prof[:, 2])]
    # jaw corners: the side of the jaw under the ears
    for sgn, fp in ((1, "2.13"), (-1, "2.14")):
        at[fp] = raycast(F, _dirs_to(d, [[sgn * 70.0, -90.0, 6.0]]))[0]
    # points at designed places of the face plane, all cast at once
    chin_y = at["2.10"][1]
    places = {"9.15": (0.0, d.nose_base_y), "9.1": (17.5 * N, -41.0), "9.2": (-17.5 * N, -41.0),
              "9.5": (11.0 * N, -46.0), "9.4": (-11.0 * N, -46.0), "9.7": (6.0, 2.0),
              "9.6": (-6.0, 2.0), "9.12": (0.0, -16.0), "9.13": (7.5 * N, -18.0),
              "9.14": (-7.5 * N, -18.0), "5.1": (40.0 * W, -42.0), "5.2": (-40.0 * W, -42.0),
              "5.3": (44.0 * W, -22.0), "5.4": (-44.0 * W, -22.0),
              "2.11": (17.0 * J, chin_y - 7.0), "2.12": (-17.0 * J, chin_y - 7.0),
              "11.1": (0.0, 59.5), "11.3": (43.0 * W, 52.0), "11.2": (-43.0 * W, 52.0)}
    for sgn, ids in ((1, ("4.1", "4.3", "4.5")), (-1, ("4.2", "4.4", "4.6"))):
        places[ids[0]] = (sgn * (d.eye_x - 17.0), 19.5)
        places[ids[1]] = (sgn * (d.eye_x + 1.0), 24.5)
        places[ids[2]] = (sgn * (d.eye_x + 16.5), 20.0)
    pts = surface_at_xy(F, np.array(list(places.values())))
    at.update(zip(places, pts))
    # ears: where they stand off the head (with and without them)
    ay, az = np.meshgrid(np.linspace(-60, 30, 91), np.linspace(-40, 20, 61), indexing="ij")
    sides = ((1, ("10.1", "10.3", "10.5", "10.7", "10.9")),
             (-1, ("10.2", "10.4", "10.6", "10.8", "10.10")))
    target = np.concatenate([np.column_stack([np.full(ay.size, sgn * 100.0), ay.ravel(), az.ravel()])
                             for sgn, _ in sides])
    dirs = _dirs_to(d, target)
    with_ear = raycast(F, dirs)
    excess = (np.linalg.norm(with_ear - d.origin, axis=1)
              - np.linalg.norm(raycast(F_noear, dirs) - d.origin, axis=1))
    for half, (sgn, ids) in enumerate(sides):
        sl = slice(half * ay.size, (half + 1) * ay.size)
        P, ex = with_ear[sl], excess[sl]
        pts = P[ex > 3.0]
        at[ids[0]] = pts[np.argmax(pts[:, 1])]
        at[ids[1]] = pts[np.argmin(pts[:, 2])]
        at[ids[2]] = pts[np.argmin(pts[:, 1])]
        # contact points: where the rim meets the head, in front of the ear's middle
        rim = np.abs(ex - 1.0) + 50.0 * (P[:, 2] < -8.0)
        low = P[:, 1] < (at[ids[2]][1] + at[ids[0]][1]) / 2
        at[ids[3]] = P[np.argmin(rim + 0.2 * np.abs(P[:, 1] - at[ids[2]][1] - 4) + 99 * ~low)]
        at[ids[4]] = P[np.argmin(rim + 0.2 * np.abs(P[:, 1] - at[ids[0]][1] + 4) + 99 * low)]
    return at


# -- background -----------------------------------------------------------------------------
def _spiral(axis: np.ndarray, spacing: np.ndarray, angles: np.ndarray,
            rng: np.random.Generator) -> tuple:
    """A golden-angle (sunflower) spiral of directions round ``axis`` out to
    ``angles[-1]``, the angular spacing growing as ``spacing`` (tabulated at ``angles``),
    each point jittered by a fifth of its spacing.  Returns (directions, spacing)."""
    axis = axis / np.linalg.norm(axis)
    density = 1.0 / (spacing ** 2 * np.sqrt(3) / 2)
    dn = 2 * np.pi * np.sin(angles) * density
    cum = np.concatenate([[0], np.cumsum(0.5 * (dn[1:] + dn[:-1]) * np.diff(angles))])
    n = int(cum[-1])
    k = np.arange(n) + 0.5
    alpha = np.interp(k, cum, angles)
    beta = k * np.pi * (3 - np.sqrt(5))
    local = np.interp(alpha, angles, spacing)
    alpha = np.clip(alpha + rng.uniform(-1, 1, n) * 0.2 * local, 1e-4, np.pi - 1e-4)
    beta = beta + rng.uniform(-1, 1, n) * 0.2 * local / np.maximum(np.sin(alpha), 1e-3)
    e1 = np.cross(axis, [1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    dirs = (np.cos(alpha)[:, None] * axis + np.sin(alpha)[:, None]
            * (np.cos(beta)[:, None] * e2 + np.sin(beta)[:, None] * e1))
    return dirs / np.linalg.norm(dirs, axis=1, keepdims=True), np.interp(alpha, angles, spacing)


def _sunflower(d: Design, res: float, seed: int) -> tuple:
    """Background directions: a spiral round the face, spacing growing from about 2.8 mm
    on the face's middle to 8.5 mm behind the head, with finer spirals round the ears;
    jittered by ``seed``.  Returns (directions, spacing in mm)."""
    rng = np.random.default_rng(seed)
    h_face, h_back, r = 4.3 / np.sqrt(res), 9.5 / np.sqrt(res), 110.0
    a = np.linspace(0, np.pi, 4001)
    deg = np.degrees(a)
    spacing = (0.72 * h_face + 0.28 * h_face * smoothstep((deg - 32) / 8)
               + (h_back - h_face) * smoothstep((deg - 48) / 34)) / r
    axis = np.array([0.0, -0.05, 1.0])
    dirs, sp = _spiral(axis, spacing, a, rng)
    out_d, out_s = [dirs], [sp]
    # the ears: finer spirals, matching the background's spacing at their rims
    cap = np.radians(26.0)
    for sgn in (1, -1):
        ear_axis = np.array([sgn * 80.0 * d.W, -13.0, -14.0]) - d.origin
        ear_axis /= np.linalg.norm(ear_axis)
        keep = [np.arccos(np.clip(o @ ear_axis, -1, 1)) > cap for o in out_d]
        out_d = [o[k] for o, k in zip(out_d, keep)]
        out_s = [o[k] for o, k in zip(out_s, keep)]
        outer = np.interp(np.arccos(np.clip(ear_axis @ axis / np.linalg.norm(axis), -1, 1)), a, spacing)
        b = np.linspace(0, cap, 600)
        local = (0.75 * h_face / r) + (outer - 0.75 * h_face / r) * smoothstep((b - 0.55 * cap) / (0.45 * cap))
        ed, es = _spiral(ear_axis, local, b, rng)
        out_d.append(ed)
        out_s.append(es)
    return np.concatenate(out_d), np.concatenate(out_s) * r


def _inside(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Even-odd test of 2-D points in a polygon, vectorised over points and edges."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    x0, y0 = poly[:, 0][None], poly[:, 1][None]
    x1, y1 = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    cross = (y0 > y) != (y1 > y)
    xs = x0 + (y - y0) * (x1 - x0) / np.where(y1 != y0, y1 - y0, 1.0)
    return ((cross & (x < xs)).sum(axis=1) % 2) == 1


# -- assembly ---------------------------------------------------------------------------------
def build_skin(d: Design, resolution: float = 1.0, seed: int = 0) -> Skin:
    """The skin of the reference head (mm) with its patches and feature points."""
    F = HeadSurface(d)
    F_noear = HeadSurface(d, ears=False)
    patches = [_mouth_patch(F, d, resolution), _eye_patch(F, d, resolution, 1),
               _eye_patch(F, d, resolution, -1)]
    marks = _landmarks(F, F_noear, d)
    mark_ids = list(marks)
    mark_pts = np.array([marks[k] for k in mark_ids])
    # background: directions, their surface points; drop those under or near patches
    dirs, spacing = _sunflower(d, resolution, seed)
    P = raycast(F, dirs)
    keep = np.ones(len(P), bool)
    front = P[:, 2] > 20.0
    rings = []
    for p in patches:
        ring = p.xyz[-1]
        rings.append(ring)
        # grow the outline a little so that no point sits just outside a ring edge
        ctr = p.outline.mean(axis=0)
        grown = ctr + (p.outline - ctr) * 1.06
        keep &= ~(front & _inside(grown, P[:, :2]))
        step = np.linalg.norm(ring - np.roll(ring, 1, axis=0), axis=1)
        near = cKDTree(ring).query(P, k=1)
        reach = np.maximum(step[near[1]], np.roll(step, -1)[near[1]])
        keep &= near[0] > 0.75 * np.maximum(reach, spacing)
    dist, _ = cKDTree(mark_pts).query(P, k=1)
    keep &= dist > 0.6 * spacing
    P = P[keep]
    ring_pts = np.concatenate(rings)
    hull_pts = np.concatenate([P, mark_pts, ring_pts])
    hull_dirs = _dirs_to(d, hull_pts)
    hull = ConvexHull(hull_dirs)
    if len(hull.vertices) != len(hull_pts):
        raise RuntimeError("the skin's directions are not all on their hull (duplicates?)")
    tri = hull.simplices.copy()
    nrm = np.cross(hull_dirs[tri[:, 1]] - hull_dirs[tri[:, 0]], hull_dirs[tri[:, 2]] - hull_dirs[tri[:, 0]])
    flip = np.einsum("ij,ij->i", nrm, hull_dirs[tri].sum(axis=1)) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    # drop hull triangles under a patch
    n_bg = len(P) + len(mark_pts)
    ring_first = [n_bg]
    for r in rings[:-1]:
        ring_first.append(ring_first[-1] + len(r))
    cen = hull_pts[tri].mean(axis=1)
    drop = np.zeros(len(tri), bool)
    for p, first in zip(patches, ring_first):
        ring_n = p.xyz.shape[1]
        all_ring = (tri >= first) & (tri < first + ring_n)
        inside = (cen[:, 2] > 20.0) & _inside(p.outline, cen[:, :2])
        drop |= all_ring.all(axis=1) & inside
    tri = tri[~drop]
    # every ring edge must be in the hull triangulation
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    have = set(map(tuple, edges.tolist()))
    for p, first in zip(patches, ring_first):
        ring_n = p.xyz.shape[1]
        j = np.arange(ring_n)
        want = np.sort(np.column_stack([first + j, first + (j + 1) % ring_n]), axis=1)
        missing = [e for e in map(tuple, want.tolist()) if e not in have]
        if missing:
            raise RuntimeError(f"patch {p.kind}: {len(missing)} outline edges are not in the "
                               "background triangulation")
    # vertices: background + landmarks + patch outer rings (shared), then patch interiors
    verts, tris, index = [hull_pts], [tri], {}
    n_v = len(hull_pts)
    for p, ring0 in zip(patches, ring_first):
        R, C = p.xyz.shape[:2]
        verts.append(p.xyz[:-1].reshape(-1, 3))
        # local index (r, j) -> global: inner rings from ``n_v`` on, outer ring at ``ring0``
        gi = np.concatenate([n_v + np.arange((R - 1) * C), ring0 + np.arange(C)])
        tris.append(gi[p.triangles(0)])
        index[p.kind] = gi.reshape(R, C)
        n_v += (R - 1) * C
    V = np.concatenate(verts)
    T = np.concatenate(tris)
    patch_id = np.zeros(len(V), np.int8)
    cc = np.zeros(len(V))
    tt = np.full(len(V), np.inf)
    sd = np.zeros(len(V), np.int8)
    for p in patches:
        gi = index[p.kind]
        _, c, _, side = _ring_columns(p.n)
        patch_id[gi] = p.kind
        cc[gi] = c[None, :]
        tt[gi] = p.t[:, None]
        sd[gi] = side[None, :]
    # feature points
    points = {k: len(P) + i for i, k in enumerate(mark_ids)}
    m = index[PATCH_MOUTH]
    pm = patches[0]
    n = pm.n
    r_in = 3                                              # the inner contour ring
    r_out = r_in + int(np.flatnonzero(np.isclose(pm.t[r_in:], 1.0))[0])
    j = lambda deg: int(round(deg / 180 * n)) % (2 * n)   # noqa: E731 - column at an angle
    points.update({"2.2": m[r_in, j(90)], "2.3": m[r_in, j(270)], "2.4": m[r_in, j(0)],
                   "2.5": m[r_in, j(180)], "2.6": m[r_in, j(60)], "2.7": m[r_in, j(120)],
                   "2.8": m[r_in, j(300)], "2.9": m[r_in, j(240)],
                   "8.1": m[r_out, j(90)], "8.2": m[r_out, j(270)], "8.3": m[r_out, j(0)],
                   "8.4": m[r_out, j(180)], "8.5": m[r_out, j(60)], "8.6": m[r_out, j(120)],
                   "8.7": m[r_out, j(300)], "8.8": m[r_out, j(240)],
                   "8.10": m[r_out, j(75)], "8.9": m[r_out, j(105)]})
    for kind, ids in ((PATCH_LEFT_EYE, ("3.1", "3.3", "3.7", "3.11", "3.13", "3.9")),
                      (PATCH_RIGHT_EYE, ("3.2", "3.4", "3.12", "3.8", "3.14", "3.10"))):
        e = index[kind]
        pe = patches[1 if kind == PATCH_LEFT_EYE else 2]
        ne = pe.n
        r_m = 2
        r_c = r_m + int(np.flatnonzero(np.isclose(pe.t[r_m:], 1.0))[0])
        top, bottom = ne // 2, 3 * ne // 2
        outer_corner, inner_corner = (0, ne) if kind == PATCH_LEFT_EYE else (ne, 0)
        points.update({ids[0]: e[r_m, top], ids[1]: e[r_m, bottom], ids[2]: e[r_m, outer_corner],
                       ids[3]: e[r_m, inner_corner], ids[4]: e[r_c, top], ids[5]: e[r_c, bottom]})
    # how far the ears stand off (for the ear FAPs)
    dirs_all = _dirs_to(d, V)
    lateral = np.abs(V[:, 0]) > 45.0
    ear = np.zeros(len(V))
    if lateral.any():
        plain = raycast(F_noear, dirs_all[lateral])
        ear[lateral] = np.maximum(np.linalg.norm(V[lateral] - d.origin, axis=1)
                                  - np.linalg.norm(plain - d.origin, axis=1), 0.0)
    return Skin(V, T, {k: int(v) for k, v in points.items()}, patch_id, cc, tt, sd, ear,
                extras={"index": index, "patches": patches})
