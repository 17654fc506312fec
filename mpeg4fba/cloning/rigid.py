"""Rigid motions of the face's parts: fitting, axis-angle form, centres of rotation.

>>> R = axis_angle_matrix((0, 0, 1), np.pi / 2)
>>> x = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
>>> fit = fit_rigid(x, x @ R.T + [0, 0, 2])
>>> (np.round(fit.axis, 6) + 0.0).tolist(), round(float(np.degrees(fit.angle)), 6), round(fit.residual, 9)
([0.0, 0.0, 1.0], 90.0, 0.0)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

__all__ = ["RigidFit", "fit_rigid", "axis_angle", "axis_angle_matrix", "rotation_centre",
           "sphere_centre"]


def axis_angle_matrix(axis: Sequence[float], angle: float) -> np.ndarray:
    """The 3x3 rotation by ``angle`` (radians) about ``axis`` (right-handed)."""
    a = np.asarray(axis, dtype=np.float64).reshape(3)
    n = np.linalg.norm(a)
    if n == 0 or angle == 0:
        return np.eye(3)
    x, y, z = a / n
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def axis_angle(R: np.ndarray) -> tuple:
    """(unit axis, angle in [0, pi]) of a rotation matrix; axis (0, 0, 1) for identity.

    >>> ax, an = axis_angle(axis_angle_matrix((1, 2, 2), 0.3))
    >>> np.round(ax * 3, 6).tolist(), round(an, 9)
    ([1.0, 2.0, 2.0], 0.3)
    """
    R = np.asarray(R, dtype=np.float64)
    c = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    angle = float(np.arccos(c))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = np.linalg.norm(v)
    if angle < 1e-12:
        return np.array([0.0, 0.0, 1.0]), 0.0
    if s > 1e-9:
        return v / s + 0.0, angle
    # angle near pi: the axis is the eigenvector of eigenvalue 1 (R + I has rank 1)
    m = R + np.eye(3)
    k = int(np.argmax(np.linalg.norm(m, axis=0)))
    axis = m[:, k] / np.linalg.norm(m[:, k])
    return axis, angle


@dataclass
class RigidFit:
    """``moved ~= rotation @ x + translation``; ``residual`` is the RMS misfit and
    ``motion`` the RMS displacement it explains."""

    rotation: np.ndarray
    translation: np.ndarray
    residual: float
    motion: float

    @property
    def axis(self) -> np.ndarray:
        return axis_angle(self.rotation)[0]

    @property
    def angle(self) -> float:
        return axis_angle(self.rotation)[1]

    def is_rigid(self, tolerance: float = 0.05, floor: float = 0.0) -> bool:
        """Whether the misfit is within ``tolerance`` of the motion (or below ``floor``)."""
        return self.residual <= max(tolerance * self.motion, floor)


def fit_rigid(x: np.ndarray, moved: np.ndarray, weights: Optional[np.ndarray] = None) -> RigidFit:
    """Least-squares rigid motion (Kabsch) taking points ``x`` (n, 3) to ``moved``."""
    x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
    y = np.asarray(moved, dtype=np.float64).reshape(-1, 3)
    w = np.ones(len(x)) if weights is None else np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    cx, cy = w @ x, w @ y
    H = ((x - cx) * w[:, None]).T @ (y - cy)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    t = cy - R @ cx
    res = y - (x @ R.T + t)
    residual = float(np.sqrt(w @ (res ** 2).sum(axis=1)))
    motion = float(np.sqrt(w @ ((y - x) ** 2).sum(axis=1)))
    return RigidFit(R, t, residual, motion)


def rotation_centre(fit: RigidFit, near: Sequence[float]) -> np.ndarray:
    """The point of the fit's rotation axis nearest ``near`` (a pure translation: ``near``).

    Rotating about it, the rest of the motion is a slide along the axis; for a jaw
    this is the hinge.
    """
    p = np.asarray(near, dtype=np.float64).reshape(3)
    axis, angle = axis_angle(fit.rotation)
    if angle < 1e-9:
        return p
    A = np.eye(3) - fit.rotation
    c = np.linalg.lstsq(A, fit.translation, rcond=None)[0]
    return c + axis * float(axis @ (p - c))


def sphere_centre(points: np.ndarray) -> np.ndarray:
    """Centre of the least-squares sphere through ``points`` (an eyeball's centre).

    >>> d = np.random.default_rng(0).normal(size=(50, 3))
    >>> pts = 2 * d / np.linalg.norm(d, axis=1)[:, None] + [1, 2, 3]
    >>> np.round(sphere_centre(pts), 9).tolist()
    [1.0, 2.0, 3.0]
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) < 4:
        return p.mean(axis=0)
    A = np.column_stack([2 * p, np.ones(len(p))])
    b = (p ** 2).sum(axis=1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:3]
    if not np.all(np.isfinite(c)) or np.linalg.norm(c - p.mean(axis=0)) > np.ptp(p, axis=0).max():
        return (p.min(axis=0) + p.max(axis=0)) / 2
    return c
