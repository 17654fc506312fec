"""The reference head's shape: a design (where everything is, in millimetres) and an
implicit surface (a smooth union of rounded primitives) that rays are cast onto.

The head is star-shaped about ``Design.origin``: every ray from there leaves it once,
so a direction is a point of the skin (:func:`raycast`).  Coordinates are the face
frame: x = the face's left, y = up, z = forward; y = 0 is the pupils' level, z = 0
about the ear canals.  Everything here is millimetres; the builder scales to metres.

>>> d = Design()
>>> d.eye_x, d.lip_y, round(d.mouth_outer, 1)
(32.0, -68.0, 25.0)
>>> p = raycast(HeadSurface(d), np.array([[0.0, 0.0, 1.0]]))
>>> bool(90 < p[0, 2] < 130)                 # straight ahead: the nose, 9-13 cm forward
True
"""
from __future__ import annotations

import numpy as np

__all__ = ["Design", "HeadSurface", "raycast", "surface_at_xy", "smoothstep"]


def smoothstep(x: np.ndarray) -> np.ndarray:
    """0 below 0, 1 above 1, 3x^2 - 2x^3 between (flat at both ends)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _ellipsoid(P: np.ndarray, c, r) -> np.ndarray:
    """Approximate signed distance to an axis-aligned ellipsoid (exact on its surface)."""
    r = np.asarray(r, float)
    q = (P - np.asarray(c, float)) / r
    k0 = np.sqrt(np.einsum("ij,ij->i", q, q))
    q2 = q / r
    k1 = np.sqrt(np.einsum("ij,ij->i", q2, q2))
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _sphere(P: np.ndarray, c, r: float) -> np.ndarray:
    return np.linalg.norm(P - np.asarray(c, float), axis=1) - r


def _round_cone(P: np.ndarray, a, b, ra: float, rb: float) -> np.ndarray:
    """Distance to a capsule from ``a`` (radius ra) to ``b`` (radius rb), radius
    interpolated along it (a close approximation when the radii differ little)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    t = np.clip((P - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(P - (a + t[:, None] * ab), axis=1) - (ra + (rb - ra) * t)


def _smin(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum (a union whose seam is rounded over about ``k``)."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def _smax(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    return -_smin(-a, -b, k)


class Design:
    """Where the parts of the head are (mm), for one set of proportions.

    ``face_width`` widens the skull and face, ``jaw`` the jaw and chin, ``nose`` the
    nose, ``eye_spacing`` the distance between the eyes, ``mouth_width`` the mouth.
    """

    def __init__(self, face_width: float = 1.0, jaw: float = 1.0, nose: float = 1.0,
                 eye_spacing: float = 1.0, mouth_width: float = 1.0):
        for name, v in (("face_width", face_width), ("jaw", jaw), ("nose", nose),
                        ("eye_spacing", eye_spacing), ("mouth_width", mouth_width)):
            if not 0.8 <= float(v) <= 1.25:
                raise ValueError(f"{name} = {v}: the reference head takes 0.8 to 1.25")
        self.W, self.J, self.N = float(face_width), float(jaw), float(nose)
        self.E, self.M = float(eye_spacing), float(mouth_width)
        W, N, E, M = self.W, self.N, self.E, self.M
        self.origin = np.array([0.0, -25.0, -5.0])       # rays start here
        # Eyes: centre, eyeball, lids (a sphere a little larger than the eyeball),
        # iris; the lid opening of the neutral face is the iris diameter.
        self.eye_x = 32.0 * E
        self.eye_y = 0.0
        self.eye_z = 70.0
        self.eye_r = 12.0
        self.lid_r = 13.6
        self.iris_r = 5.6
        self.pupil_r = self.iris_r / 3.0
        self.eye_half_width = 12.5
        self.canthal_tilt = 0.9
        # Mouth: lip line, inner and outer corners, vermilion heights.
        self.lip_y = -68.0
        self.mouth_inner = 22.0 * M
        self.mouth_outer = 25.0 * M
        self.upper_lip_h = 7.2
        self.upper_lip_peak = 8.8
        self.lower_lip_h = 9.5
        self.lip_gap = 0.04          # upper and lower inner lips: touching, not coincident
        # Nose.
        self.nose_tip = np.array([0.0, -36.0, 92.0 + 19.0 * N])
        self.nose_base_y = -47.0
        # Teeth, jaw hinge, top of the spine.
        self.occlusal_y = self.lip_y - 2.5
        self.hinge = np.array([0.0, -24.0, 8.0])
        self.spine_top = np.array([0.0, -58.0, -22.0])
        self.face_width_at_cheek = 62.0 * W

    def eye_centre(self, side: int) -> np.ndarray:
        """Centre of the left (side=+1) or right (side=-1) eyeball."""
        return np.array([side * self.eye_x, self.eye_y, self.eye_z])


def _gauss(u: np.ndarray) -> np.ndarray:
    return np.exp(-u * u)


def _bump(x: np.ndarray, y: np.ndarray, cx: float, cy: float, rx: float, ry: float) -> np.ndarray:
    """A smooth bump of height 1 at (cx, cy), compact (zero beyond the ellipse (rx, ry))."""
    q = np.minimum(((x - cx) / rx) ** 2 + ((y - cy) / ry) ** 2, 1.0)
    u = 1.0 - q
    return u * u * u                                        # C2 at the rim


class _Profile:
    """A smooth (monotone cubic) function of y through control points."""

    def __init__(self, ys, vs):
        from scipy.interpolate import PchipInterpolator
        self.f = PchipInterpolator(np.asarray(ys, float), np.asarray(vs, float), extrapolate=True)
        self.lo, self.hi = float(min(ys)), float(max(ys))

    def __call__(self, y: np.ndarray) -> np.ndarray:
        return self.f(np.clip(y, self.lo, self.hi))


class HeadSurface:
    """The skin as the zero set of ``F`` (negative inside).

    The base is lofted: each horizontal section is a superellipse whose half-width,
    front and back depths and squareness follow designed profiles of the height, closed
    by domes at the top of the skull and under the chin; a neck (an elliptic cylinder)
    is smoothly joined.  Features (brows, eye sockets, nose, cheekbones, muzzle, chin,
    philtrum) are smooth height bumps of the face plane added to the front.
    ``ears=False`` leaves the ears out (to measure how far they stand off the head).
    """

    TOP = 121.0
    BOTTOM = -119.0

    def __init__(self, design: Design, ears: bool = True):
        self.d = design
        self.ears = ears
        W, J = design.W, design.J
        ys = [-119, -110, -100, -88, -70, -45, -20, 0, 20, 45, 70, 95, 110, 121]
        self.width = _Profile(ys, np.array([28, 37, 44, 50, 58, 64, 68, 70, 73, 74.5, 72, 63, 52, 44])
                              * np.array([J] * 5 + [1] * 9) * W)
        self.front = _Profile(ys, [66, 78, 84, 87.5, 90, 91, 89, 87, 91, 88, 80, 62, 44, 30])
        self.back = _Profile(ys, [8, 0, -12, -25, -45, -72, -86, -95, -100, -99, -90, -72, -55, -40])
        self.centre = _Profile(ys, [30, 22, 14, 8, 0, -4, -6, -6, -6, -6, -6, -8, -8, -8])
        self.square = _Profile(ys, [2.2, 2.4, 2.6, 2.8, 2.9, 2.9, 2.8, 2.7, 2.5, 2.3, 2.2, 2.1, 2.0, 2.0])
        self.dome_top = 88.0           # the skull closes as an ellipse above this height
        self.dome_bottom = -96.0       # and the jaw below this one
        # the features' heights, tabulated on a fine grid of the face plane
        self._gx = np.arange(-90.0, 90.0 + 1e-9, self.GRID)
        self._gy = np.arange(-135.0, 85.0 + 1e-9, self.GRID)
        gx, gy = np.meshgrid(self._gx, self._gy, indexing="ij")
        self._heights = self.features(gx.ravel(), gy.ravel()).reshape(gx.shape)

    GRID = 0.4

    def heights(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """:meth:`features` by bilinear interpolation of its table (0 off the face)."""
        g = self.GRID
        fx = (x - self._gx[0]) / g
        fy = (y - self._gy[0]) / g
        nx, ny = len(self._gx) - 1, len(self._gy) - 1
        ok = (fx >= 0) & (fx < nx) & (fy >= 0) & (fy < ny)
        i = np.clip(fx.astype(np.int64), 0, nx - 1)
        j = np.clip(fy.astype(np.int64), 0, ny - 1)
        u = np.clip(fx - i, 0.0, 1.0)
        v = np.clip(fy - j, 0.0, 1.0)
        H = self._heights
        h = ((1 - u) * ((1 - v) * H[i, j] + v * H[i, j + 1])
             + u * ((1 - v) * H[i + 1, j] + v * H[i + 1, j + 1]))
        return np.where(ok, h, 0.0)

    def _dome(self, y: np.ndarray) -> np.ndarray:
        top = np.clip((y - self.dome_top) / (self.TOP - self.dome_top), 0.0, 1.0)
        bottom = np.clip((self.dome_bottom - y) / (self.dome_bottom - self.BOTTOM), 0.0, 1.0)
        return np.sqrt(np.clip(1.0 - top ** 2, 0.0, 1.0) * np.clip(1.0 - bottom ** 2, 0.0, 1.0))

    def base(self, P: np.ndarray) -> np.ndarray:
        """The lofted head without features (approximately a distance, in mm)."""
        x, y, z = P[:, 0], P[:, 1], P[:, 2]
        dome = self._dome(y)
        a = np.maximum(self.width(y) * dome, 1e-3)
        zc = self.centre(y)
        front = z >= zc
        depth = np.where(front, self.front(y) - zc, zc - self.back(y)) * dome
        depth = np.maximum(depth, 1e-3)
        n = np.where(front, self.square(y), 2.2)
        s = (np.abs(x / a) ** n + np.abs((z - zc) / depth) ** n) ** (1.0 / n)
        outside = (y > self.TOP) | (y < self.BOTTOM)
        f = (s - 1.0) * np.minimum(a, depth)
        return np.where(outside, np.maximum(f, 1.0) + np.abs(y) - 100.0, f)

    def features(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height (mm, along the front's normal) of the face's features at (x, y)."""
        d = self.d
        W, J, N, E, M = d.W, d.J, d.N, d.E, d.M
        ax = np.abs(x)
        h = 3.2 * _bump(ax, y, 27 * E, 15.0, 24.0, 9.0)                     # brow ridges
        h += 2.0 * _bump(ax, y, 0.0, 12.0, 12.0, 12.0)                      # glabella
        h -= 8.5 * _bump(ax, y, d.eye_x, 1.0, 19.0, 14.0)                   # eye sockets
        h += 3.0 * _bump(ax, y, 45 * W, -17.0, 20.0, 14.0)                  # cheekbones
        h += 4.5 * _bump(ax, y, 32 * W, -27.0, 27.0, 24.0)                  # cheeks
        # nose: the midline profile (dorsum, round tip, underside) spread sideways
        tip_y = d.nose_tip[1]
        w = (6.0 + 3.5 * smoothstep((8.0 - y) / (8.0 - tip_y))) * N
        h += self.nose_profile(y) * np.exp(-(ax / w) ** 2)
        h += 5.5 * N * _bump(ax, y, 12.0 * N, -41.0, 8.5 * N, 7.0)             # wings
        h += 2.0 * N * _bump(ax, y, 0.0, -44.5, 5.0, 4.0)                      # columella
        # mouth: the muzzle, philtrum, the fold under the lower lip, the chin
        h += 2.5 * _bump(ax, y, 0.0, d.lip_y + 2.0, 34.0 * M, 24.0)
        h -= 0.9 * _bump(ax, y, 0.0, -55.0, 3.5, 8.0)
        h -= 1.2 * _bump(ax, y, 0.0, d.lip_y - 17.0, 20.0 * M, 6.0)
        h += 6.0 * J * _bump(ax, y, 0.0, -99.0, 24.0 * J, 21.0)
        return h

    @staticmethod
    def ear_height(y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """How far (mm) the ear stands off the side of the head at (y, z): an auricle
        leaning back, its rim (helix) raised, its bowl (concha) hollow, the front
        attached and the back free."""
        yc, zc, ry, rz = -13.0, -14.0, 31.0, 16.5
        a = np.radians(14.0)                         # the top leans back
        v = ((y - yc) * np.cos(a) + (z - zc) * np.sin(a)) / ry
        u = (-(y - yc) * np.sin(a) + (z - zc) * np.cos(a)) / rz
        r = np.sqrt(u * u + v * v)
        back = np.clip((1.0 - u) / 2.0, 0.0, 1.0)    # 0 at the front, 1 at the back
        lobe = smoothstep((-v - 0.45) / 0.4)
        h = 3.0 + 12.0 * back ** 1.3 * (1.0 - 0.55 * lobe)
        h += 2.6 * np.exp(-((r - 0.84) / 0.11) ** 2) * (1.0 - lobe) * smoothstep((0.6 - u) / 0.5)
        h -= 6.5 * np.exp(-((u - 0.18) / 0.33) ** 2 - ((v + 0.08) / 0.30) ** 2)
        h = np.maximum(h, 0.8)
        return h * (1.0 - smoothstep((r - 0.9) / 0.12))

    def nose_profile(self, y: np.ndarray) -> np.ndarray:
        """Height of the nose on the midline: a straight dorsum from the nasion, a round
        tip, the underside back to the base of the nose (smoothed, tabulated)."""
        if not hasattr(self, "_nose"):
            d = self.d
            tip_y, tip_h, rt = d.nose_tip[1], 20.0 * d.N, 6.5 * d.N
            ys = np.arange(-60.0, 15.0, 0.1)
            line = 2.5 + (tip_h - 3.5 - 2.5) * (8.0 - ys) / (8.0 - tip_y)
            line = np.where((ys <= 8.0) & (ys >= tip_y), line, 0.0)
            yc, hc = tip_y - 0.5, tip_h - rt
            circle = hc + np.sqrt(np.maximum(rt * rt - (ys - yc) ** 2, 0.0))
            circle = np.where(np.abs(ys - yc) <= rt, circle, 0.0)
            y0, h0 = yc - 0.75 * rt, hc + np.sqrt(1 - 0.75 ** 2) * rt
            under = np.interp(ys, [d.nose_base_y, y0], [1.0, h0], left=0.0, right=0.0)
            prof = np.maximum(np.maximum(line, circle), under)
            prof *= smoothstep((10.0 - ys) / 5.0) * smoothstep((ys - d.nose_base_y + 2.0) / 3.0)
            k = np.exp(-0.5 * (np.arange(-25, 26) * 0.1 / 1.2) ** 2)
            self._nose = (ys, np.convolve(prof, k / k.sum(), mode="same"))
        return np.interp(y, *self._nose)

    def __call__(self, P: np.ndarray) -> np.ndarray:
        d = self.d
        x, y, z = P[:, 0], P[:, 1], P[:, 2]
        f = self.base(P)
        front = smoothstep((z - 15.0) / 40.0)
        f = f - self.heights(x, y) * front
        # neck: an elliptic cylinder, rounded into the head, cut flat at the bottom
        q = np.sqrt((x / (54 * d.W)) ** 2 + ((z + 12) / 54) ** 2)
        neck = _smax((q - 1.0) * 54, np.maximum(-170 - y, y + 30), 12.0)
        f = _smin(f, neck, 14)
        Pm = P.copy()
        Pm[:, 0] = np.abs(x)
        # the lids: a sphere round each eyeball, standing in the socket
        f = _smin(f, _sphere(Pm, (d.eye_x, d.eye_y, d.eye_z), d.lid_r), 2.5)
        if self.ears:
            f = f - self.ear_height(y, z) * smoothstep((np.abs(x) - 50.0 * d.W) / 12.0)
        return f


def raycast(F, dirs: np.ndarray, origin: np.ndarray = None, lo: float = 12.0,
            hi: float = 320.0, iters: int = 27) -> np.ndarray:
    """Where rays from ``origin`` (default: the design's) along unit ``dirs`` leave the
    surface ``F`` (bisection; the head is star-shaped about the origin)."""
    o = np.asarray(F.d.origin if origin is None else origin, float)
    dirs = np.asarray(dirs, float)
    a = np.full(len(dirs), lo)
    b = np.full(len(dirs), hi)
    for _ in range(iters):
        m = 0.5 * (a + b)
        inside = F(o + m[:, None] * dirs) < 0
        a = np.where(inside, m, a)
        b = np.where(inside, b, m)
    r = 0.5 * (a + b)
    return o + r[:, None] * dirs


def surface_at_xy(F, xy: np.ndarray, z0: float = 85.0, iters: int = 5) -> np.ndarray:
    """Points of the front of the surface at given (x, y): cast a ray at (x, y, z), take
    the z it hits, again (converges on a surface that faces forward there)."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    z = np.full(len(xy), z0)
    o = F.d.origin
    for _ in range(iters):
        d = np.column_stack([xy, z]) - o
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        p = raycast(F, d)
        z = p[:, 2]
    return p
