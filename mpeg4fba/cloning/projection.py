"""The 2D alignment space of Pandzic, *Facial Motion Cloning* (cylindrical projection).

Normalised faces are projected around a vertical (y) axis through ``(center_x, center_z)``
to ``(angle, y)``.  The angle is measured in the x-z plane, zero at the nose tip (FP 9.3),
**positive toward the face's left (+x)** (with the face looking along +z, a point at
``+x`` in front of the axis has a positive angle), increasing around the head and wrapped
to ``(-pi, pi]``: the back of the head, straight opposite the nose, is ``+pi``.

The axis (:func:`choose_axis`) is placed behind the mouth so that the lip corners
8.3 and 8.4 always subtend the same angle ``mouth_angle`` (default
:data:`MOUTH_ANGLE`), which with the nose at zero roughly aligns any two faces.

>>> from mpeg4fba.fba.featurepoints import FeaturePointSet
>>> fp = FeaturePointSet({"8.3": (1, -1, 2), "8.4": (-1, -1, 2), "9.3": (0, 0, 3)})
>>> proj = Projection(fp, mouth_angle=np.pi / 2)    # axis 1 behind the mouth: 90 degrees
>>> round(proj.center_x, 9), round(proj.center_z, 9)
(0.0, 1.0)
>>> np.round(proj(np.array([[1.0, -1.0, 2.0], [0.0, 5.0, 3.0], [0.0, 0.0, -4.0]])), 6).tolist()
[[0.785398, -1.0], [0.0, 5.0], [3.141593, 0.0]]
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..fba.featurepoints import FeaturePointSet

__all__ = ["cylindrical_projection", "choose_axis", "Projection", "MOUTH_ANGLE", "wrap_angle"]

#: Default angle (radians) the outer lip corners 8.3/8.4 subtend at the projection axis:
#: 45 degrees, about what a human mouth subtends at the head's vertical axis.
MOUTH_ANGLE = np.pi / 4


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped into ``(-pi, pi]``.

    >>> wrap_angle(np.array([0.0, np.pi, -np.pi, 3 * np.pi / 2])) / np.pi
    array([ 0. ,  1. ,  1. , -0.5])
    """
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=np.float64), 2 * np.pi)


def cylindrical_projection(points3d: np.ndarray, *, center_x: float, center_z: float,
                           nose_tip: Sequence[float]) -> np.ndarray:
    """(n, 2) ``(angle, y)`` of ``points3d`` around the vertical axis at (center_x, center_z).

    The angle is ``atan2(dx, dz)`` minus the nose tip's, wrapped to ``(-pi, pi]``;
    positive toward +x (the face's left).  Points on the axis get the angle 0 - the
    nose's, i.e. an arbitrary but finite value.

    >>> cylindrical_projection(np.array([[1.0, 2.0, 0.0]]), center_x=0, center_z=0,
    ...                        nose_tip=(0, 0, 1)).round(6).tolist()
    [[1.570796, 2.0]]
    """
    p = np.asarray(points3d, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"expected an (n, 3) array, got shape {p.shape}")
    nose = np.asarray(nose_tip, dtype=np.float64).reshape(3)
    zero = np.arctan2(nose[0] - center_x, nose[2] - center_z)
    angle = wrap_angle(np.arctan2(p[:, 0] - center_x, p[:, 2] - center_z) - zero)
    return np.column_stack([angle, p[:, 1]])


def choose_axis(points: FeaturePointSet, mouth_angle: float = MOUTH_ANGLE) -> tuple:
    """(center_x, center_z) of the axis from which the lip corners subtend ``mouth_angle``.

    With the outer lip corners 8.3 and 8.4 projected on the x-z plane at distance ``L``
    apart, the axis is on the perpendicular bisector of that segment, on the side away
    from the face's front (-z, behind the mouth), at ``h = (L / 2) / tan(mouth_angle / 2)``
    from the segment's midpoint.  So the mouth's angular width in the projection is
    exactly ``mouth_angle`` on every face (wider mouths get an axis further back).

    >>> fp = FeaturePointSet({"8.3": (2, 0, 1), "8.4": (-2, 0, 1)})
    >>> [round(v, 9) for v in choose_axis(fp, np.pi / 2)]
    [0.0, -1.0]
    """
    if not 0 < mouth_angle < np.pi:
        raise ValueError(f"mouth_angle must be in (0, pi), got {mouth_angle}")
    points.require(("8.3", "8.4"), "the projection axis")
    left, right = points["8.3"][[0, 2]], points["8.4"][[0, 2]]
    chord = left - right
    length = float(np.hypot(*chord))
    if length == 0:
        raise ValueError("the lip corners 8.3 and 8.4 coincide in the x-z plane")
    # unit normal to the chord (x, z) -> (-z, x) rotated to point forward (+z) for a face
    # with its left at +x; the axis is behind: midpoint - h * normal.
    normal = np.array([-chord[1], chord[0]]) / length
    h = 0.5 * length / np.tan(0.5 * mouth_angle)
    cx, cz = 0.5 * (left + right) - h * normal
    return float(cx), float(cz)


class Projection:
    """The cylindrical projection of one (normalised) face: axis from :func:`choose_axis`,
    zero angle at its nose tip 9.3; call it on (n, 3) vertices to get (n, 2) ``(angle, y)``.

    ``points`` must be in the same space as the vertices projected (e.g. the output of
    :meth:`Normaliser.normalise_points <mpeg4fba.cloning.normalise.Normaliser.normalise_points>`).
    """

    def __init__(self, points: FeaturePointSet, mouth_angle: float = MOUTH_ANGLE):
        points.require(("8.3", "8.4", "9.3"), "the cylindrical projection")
        self.mouth_angle = float(mouth_angle)
        self.center_x, self.center_z = choose_axis(points, mouth_angle)
        self.nose_tip = np.array(points["9.3"], dtype=np.float64)

    def __call__(self, vertices: np.ndarray) -> np.ndarray:
        return cylindrical_projection(vertices, center_x=self.center_x,
                                      center_z=self.center_z, nose_tip=self.nose_tip)

    def __repr__(self) -> str:
        return (f"<Projection axis x={self.center_x:g} z={self.center_z:g}, "
                f"mouth {np.degrees(self.mouth_angle):g} deg>")
