"""The reference head's other meshes: eyeballs, teeth, tongue, mouth cavity, hair and
the top of the spine (millimetres, each in the frame of the Transform it hangs under).

Every builder returns a :class:`Part`: vertices, triangles (wound outward), a colour
per vertex, and the vertex index of each feature point it carries.

>>> eye = eyeball(Design())
>>> eye.vertices[eye.points["pupil"]].tolist()       # the pupil's centre looks along +z
[0.0, 0.0, 12.0]
>>> eye.colors[0].round(2).tolist(), eye.colors[-1].round(2).tolist()   # pupil, sclera
([0.04, 0.04, 0.05], [0.95, 0.94, 0.91])
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._shape import Design, smoothstep

__all__ = ["Part", "eyeball", "teeth", "tongue", "mouth_cavity", "hair", "spine",
           "SKIN", "LIP", "HAIR", "BROW"]

SKIN = np.array([0.90, 0.73, 0.62])
LIP = np.array([0.74, 0.40, 0.40])
HAIR = np.array([0.24, 0.16, 0.10])
BROW = np.array([0.30, 0.20, 0.13])
_SCLERA = np.array([0.95, 0.94, 0.91])
_IRIS = np.array([0.30, 0.45, 0.58])
_PUPIL = np.array([0.04, 0.04, 0.05])
_TOOTH = np.array([0.95, 0.93, 0.86])
_GUM = np.array([0.82, 0.47, 0.47])
_TONGUE = np.array([0.86, 0.50, 0.52])
_CAVITY = np.array([0.30, 0.08, 0.09])


@dataclass
class Part:
    vertices: np.ndarray
    triangles: np.ndarray
    colors: np.ndarray
    points: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)


def _grid_triangles(rows: int, cols: int, wrap: bool = True, first: int = 0) -> np.ndarray:
    """Quads of a rows x cols grid of vertices (row-major), two triangles each; columns
    wrap round when ``wrap``.  Wound so that (row down, column across) faces outward."""
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols if wrap else cols - 1), indexing="ij")
    a = first + r * cols + c
    b = first + r * cols + (c + 1) % cols
    return np.concatenate([np.stack([a, a + cols, b + cols], -1).reshape(-1, 3),
                           np.stack([a, b + cols, b], -1).reshape(-1, 3)])


def _pole_fans(n_rings: int, cols: int) -> np.ndarray:
    """Fans joining vertex 0 (front pole) to ring 0 and the last vertex (back pole) to the
    last ring, for a sphere-like layout [pole, rings..., pole]."""
    j = np.arange(cols)
    front = np.stack([np.zeros(cols, int), 1 + j, 1 + (j + 1) % cols], -1)
    last = 1 + (n_rings - 1) * cols
    back_pole = 1 + n_rings * cols
    back = np.stack([np.full(cols, back_pole), last + (j + 1) % cols, last + j], -1)
    return np.concatenate([front, back])


def _sphere_like(radius_xyz, thetas: np.ndarray, cols: int, centre=(0.0, 0.0, 0.0)):
    """Vertices [front pole, rings at polar angles ``thetas`` (from +z), back pole]."""
    beta = 2 * np.pi * np.arange(cols) / cols
    th = np.asarray(thetas)[:, None]
    ring = np.stack([np.sin(th) * np.cos(beta), np.sin(th) * np.sin(beta),
                     np.cos(th) * np.ones_like(beta)], -1).reshape(-1, 3)
    V = np.concatenate([[[0, 0, 1.0]], ring, [[0, 0, -1.0]]]) * np.asarray(radius_xyz) + centre
    T = np.concatenate([_pole_fans(len(thetas), cols),
                        _grid_triangles(len(thetas), cols, first=1)])
    return V, T


def eyeball(d: Design, resolution: float = 1.0) -> Part:
    """An eyeball centred at the origin, looking along +z: a sphere with a pupil and an
    iris (rings at their borders, so the colours are crisp and the pupil can dilate).
    Vertex 0 is the centre of the pupil."""
    cols = 16 * max(2, int(round(2 * resolution)))
    R = d.eye_r
    tp = np.arcsin(d.pupil_r / R)
    ti = np.arcsin(d.iris_r / R)
    sclera = np.radians(np.linspace(np.degrees(ti) + 12, 168, max(6, int(round(11 * resolution)))))
    thetas = np.concatenate([[tp * 0.5, tp, tp + 0.006], np.linspace(tp, ti, 5)[1:-1] + 0.003,
                             [ti - 0.008, ti, ti + 0.01], sclera])
    V, T = _sphere_like((R, R, R), thetas, cols)
    th = np.arccos(np.clip(V[:, 2] / R, -1, 1))
    u = np.clip((th - tp) / (ti - tp), 0, 1)
    iris = _IRIS * (0.75 + 0.35 * np.sin(np.pi * u)[:, None]) * (1 - 0.45 * smoothstep((u - 0.8) / 0.2))[:, None]
    colors = np.where((th <= tp + 1e-9)[:, None], _PUPIL,
                      np.where((th <= ti + 1e-9)[:, None], iris, _SCLERA))
    # dilation: the pupil's border ring moves out along the sphere, the iris gives way
    tangent = np.column_stack([V[:, 0], V[:, 1], np.zeros(len(V))])
    rr = np.linalg.norm(tangent, axis=1)
    tangent = tangent / np.where(rr > 0, rr, 1)[:, None]
    tangent = tangent * np.cos(th)[:, None] - np.column_stack([np.zeros((len(V), 2)), np.sin(th)])
    share = np.where(th <= tp + 0.007, th / tp, np.where(th < ti, (ti - th) / (ti - tp), 0.0))
    share = np.clip(share, 0, 1)
    dilate = tangent * (share / np.cos(th))[:, None]      # mm per mm of pupil radius
    return Part(V, T, colors, {"pupil": 0}, {"dilate": dilate, "ring_pupil": np.flatnonzero(np.abs(th - tp) < 1e-9)})


def _arch(s: np.ndarray, front_z: float, half: float = 25.0, depth: float = 31.0) -> tuple:
    """A dental arch: points and outward unit normals at parameter s in [-1, 1]."""
    x = half * np.sin(s * np.pi / 2 * 0.92) / np.sin(np.pi / 2 * 0.92)
    z = front_z - depth * s * s
    dx = np.gradient(x)
    dz = np.gradient(z)
    n = np.column_stack([dz, np.zeros_like(dz), -dx])
    n = -n / np.linalg.norm(n, axis=1, keepdims=True)
    return np.column_stack([x, np.zeros_like(x), z]), n


def teeth(d: Design, front_z: float, upper: bool, resolution: float = 1.0) -> Part:
    """A row of teeth in its gum, round the dental arch: upper teeth hang from the gum
    down to the occlusal line, lower ones stand up to it.  Feature points: 9.8 / 9.10
    (top and bottom of the upper teeth) or 9.9 / 9.11 (bottom and top of the lower)."""
    cols = 2 * max(16, int(round(28 * resolution))) + 1      # odd: a column on the midline
    s = np.linspace(-1, 1, cols)
    base, normal = _arch(s, front_z if upper else front_z - 3.0, half=25.0 if upper else 23.0,
                         depth=31.0 if upper else 29.5)
    # tooth boundaries along the arch (mm from the midline): incisors, canine, premolars, molars
    length = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(base, axis=0), axis=1))])
    length -= length[cols // 2]
    widths = np.array([8.5, 6.5, 7.5, 7.0, 7.0, 10.0, 10.0]) * (1.0 if upper else 0.78)
    edges = np.concatenate([[0], np.cumsum(widths)])
    pos = np.interp(np.abs(length), edges, np.arange(len(edges)))
    frac = pos - np.floor(pos)
    notch = np.exp(-((np.minimum(frac, 1 - frac)) / 0.09) ** 2)           # 1 at a boundary
    crown = (10.0 if upper else 9.0) - 2.0 * smoothstep(np.abs(s) / 0.6 - 0.3)
    thick = 6.0 + 4.0 * smoothstep((np.abs(s) - 0.3) / 0.5)
    sign = 1.0 if upper else -1.0
    y0 = d.occlusal_y + (0.0 if upper else 1.0)
    # profile rows: edge front, gum line front (twice: tooth / gum), gum top front,
    # gum top back, gum line back (twice), edge back
    edge_lift = 0.7 * notch
    rows_n = [0.0, 0.0, 0.0, 0.3, -thick - 1.5, -thick, -thick, -1.6]
    rows_v = [edge_lift, crown, crown + 0.05, crown + 3.5, crown + 3.5, crown + 0.05, crown, edge_lift + 0.2]
    V = []
    for rn, rv in zip(rows_n, rows_v):
        rn = np.broadcast_to(rn, s.shape)
        rv = np.broadcast_to(rv, s.shape)
        p = base + normal * rn[:, None]
        p[:, 1] = y0 + sign * rv
        V.append(p)
    V = np.stack(V)                                   # [rows, cols, 3]
    rows = len(V)
    # a closed band: rows wrap round (edge front ... edge back -> edge front)
    Vf = V.transpose(1, 0, 2).reshape(-1, 3)          # column-major: column k has ``rows`` vertices
    T = _grid_triangles(cols, rows, wrap=True)        # "rows" of this grid are arch columns
    # caps at both ends of the arch (fans round each end's profile)
    n0 = len(Vf)
    Vf = np.concatenate([Vf, [V[:, 0].mean(axis=0), V[:, -1].mean(axis=0)]])
    j = np.arange(rows)
    cap0 = np.stack([np.full(rows, n0), j, (j + 1) % rows], -1)
    last = (cols - 1) * rows
    cap1 = np.stack([np.full(rows, n0 + 1), last + (j + 1) % rows, last + j], -1)
    T = np.concatenate([T, cap0, cap1])
    tooth_rows = np.array([1, 1, 0, 0, 0, 0, 1, 1], bool)       # per profile row
    is_tooth = np.concatenate([np.tile(tooth_rows, cols), [False, False]])
    shade = np.concatenate([np.repeat(1 - 0.35 * notch, rows), [1, 1]])
    colors = np.where(is_tooth[:, None], _TOOTH * shade[:, None], _GUM)
    mid = cols // 2
    pts = {"9.10": mid * rows + 0, "9.8": mid * rows + 1} if upper else \
          {"9.11": mid * rows + 0, "9.9": mid * rows + 1}
    part = Part(Vf, T, colors, pts)
    _orient_outward(part)
    return part


def _orient_outward(part: Part) -> None:
    """Flip the winding of a closed, consistently wound mesh if its volume is negative."""
    V, T = part.vertices, part.triangles
    vol = np.einsum("ij,ij->i", V[T[:, 0]], np.cross(V[T[:, 1]], V[T[:, 2]])).sum()
    if vol < 0:
        part.triangles = T[:, [0, 2, 1]]


def tongue(d: Design, tip_z: float, resolution: float = 1.0) -> Part:
    """The tongue, flat and horizontal, its tip touching the teeth from behind.  A
    deformed sphere with its front pole at the tip: feature points 6.1 (tip), 6.2 (the
    middle of its top), 6.3 / 6.4 (its left and right borders)."""
    cols = 8 * max(3, int(round(4 * resolution)))            # multiple of 4
    n_rings = max(8, int(round(12 * resolution)))
    thetas = np.linspace(0, np.pi, n_rings + 2)[1:-1]
    L, Wd, H = 50.0, 21.0, 9.0
    V, T = _sphere_like((1, 1, 1), thetas, cols)
    th = np.arccos(np.clip(V[:, 2], -1, 1))
    side_x, side_y = V[:, 0], V[:, 1]
    # spoon shape: wide and flat on top, rounder below, narrowing to the tip
    narrow = 0.55 + 0.45 * smoothstep(th / 1.3)
    x = Wd * side_x * narrow
    y = np.where(side_y > 0, 0.55 * H * side_y, 1.2 * H * side_y) - 0.4 * H * (1 - np.cos(th)) * 0.3
    z = L / 2 * np.cos(th)
    V = np.column_stack([x, y, z])
    top = V[0].copy()
    V += np.array([0.0, d.occlusal_y - 0.8, tip_z - L / 2]) - np.array([0, top[1], 0])
    colors = np.tile(_TONGUE, (len(V), 1)) * (0.9 + 0.1 * (side_y > 0))[:, None]
    ring = 1 + (n_rings // 2 - 1) * cols        # the ring nearest the middle
    pts = {"6.1": 0, "6.2": ring + cols // 4, "6.3": ring + 0, "6.4": ring + cols // 2}
    return Part(V, T, colors, pts)


def mouth_cavity(d: Design, front_z: float, resolution: float = 1.0) -> Part:
    """The inside of the mouth: a dark closed shell round teeth and tongue, wound
    inward (its normals point in), so that a renderer culling back faces shows its far
    wall behind the teeth and never its near one in front of them."""
    cols = 8 * max(2, int(round(3 * resolution)))
    thetas = np.linspace(0, np.pi, max(8, int(round(10 * resolution))) + 2)[1:-1]
    V, T = _sphere_like((29.0, 21.0, 33.0), thetas, cols,
                        centre=(0.0, d.occlusal_y + 1.0, front_z - 26.0))
    shade = 0.55 + 0.45 * smoothstep((V[:, 2] - (front_z - 50.0)) / 45.0)
    return Part(V, T[:, [0, 2, 1]], _CAVITY * shade[:, None])


def hairline(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """How far (mm) above the hairline a point of the head is (negative: below it)."""
    az = np.degrees(np.abs(np.arctan2(x, z + 10.0)))
    line = np.interp(az, [0, 25, 40, 55, 63, 72, 82, 95, 112, 128, 150, 180],
                     [59, 57, 51, 40, 8, 4, 20, 24, 24, 0, -38, -50])
    return y - line


def hair(skin_v: np.ndarray, skin_t: np.ndarray, skin_colors: np.ndarray,
         thickness: float = 6.0) -> tuple:
    """A shell of hair over the skull: the skin's triangles near and above the
    hairline, lifted along the skin's normals (thickening from nothing at the hairline,
    where its colour is the skin's).  Returns the Part and, for each hair vertex, the
    skin vertex it lies over."""
    above = hairline(*skin_v.T)
    keep = (above[skin_t] > -5.0).any(axis=1)
    tri = skin_t[keep]
    used = np.unique(tri)
    remap = np.full(len(skin_v), -1)
    remap[used] = np.arange(len(used))
    fn = np.cross(skin_v[skin_t[:, 1]] - skin_v[skin_t[:, 0]], skin_v[skin_t[:, 2]] - skin_v[skin_t[:, 0]])
    vn = np.zeros_like(skin_v)
    for k in range(3):
        np.add.at(vn, skin_t[:, k], fn)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-12)
    a = above[used]
    top = smoothstep((skin_v[used, 1] - 60.0) / 50.0)
    lift = thickness * (0.7 + 0.6 * top) * smoothstep(a / 14.0)
    V = skin_v[used] + vn[used] * lift[:, None]
    shade = HAIR * (0.85 + 0.3 * smoothstep(a / 30.0))[:, None]
    mix = smoothstep((a + 4.0) / 11.0)[:, None]
    colors = skin_colors[used] * (1 - mix) + shade * mix
    return Part(V, remap[tri], colors), used


def spine(d: Design) -> Part:
    """The top of the spine, a thin hidden rod in the neck: its top vertex is FP 7.1,
    the centre the head turns about."""
    cols = 8
    top = d.spine_top
    beta = 2 * np.pi * np.arange(cols) / cols
    ring = np.column_stack([6 * np.cos(beta), np.zeros(cols), 6 * np.sin(beta)])
    V = np.concatenate([[top], top + ring + (0, -3, 0), top + ring + (0, -80, 0),
                        [top + (0, -83, 0)]])
    T = np.concatenate([_pole_fans(2, cols), _grid_triangles(2, cols, first=1)])
    part = Part(V, T, np.tile([0.8, 0.8, 0.75], (len(V), 1)), {"7.1": 0})
    _orient_outward(part)
    return part
