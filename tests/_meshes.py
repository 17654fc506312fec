"""Small meshes built in code for the tests (not a test module)."""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np


def tube(rings: int = 8, around: int = 24, radius: float = 1.0, top: float = 0.0,
         bottom: float = -2.0, profile: Optional[Callable] = None) -> tuple:
    """An open cylinder round the y axis from ``top`` down to ``bottom``: (V, T), rings
    of ``around`` vertices from the top ring to the bottom one.  ``profile(y)`` scales
    the radius of each ring (a bulge to slide on, say)."""
    a = np.linspace(0, 2 * np.pi, around, endpoint=False)
    ys = np.linspace(top, bottom, rings)
    r = radius * (np.ones(rings) if profile is None else profile(ys))
    V = np.array([[ri * np.sin(t), y, ri * np.cos(t)] for y, ri in zip(ys, r) for t in a])
    k = np.arange((rings - 1) * around)
    p = k
    q = (k // around) * around + (k + 1) % around
    T = np.concatenate([np.stack([p, q + around, q], 1), np.stack([p, p + around, q + around], 1)])
    return V, T


def grid(nx: int = 6, ny: Optional[int] = None, spacing: float = 1.0) -> tuple:
    """A flat rectangle of triangles in the xy plane: (V, T), ``nx`` by ``ny`` (default
    ``nx``) vertices ``spacing`` apart from the origin, row by row (vertex ``y * nx + x``)."""
    ny = nx if ny is None else ny
    x, y = np.meshgrid(np.arange(nx) * float(spacing), np.arange(ny) * float(spacing))
    V = np.stack([x.ravel(), y.ravel(), np.zeros(nx * ny)], axis=1)
    k = np.arange(nx * ny).reshape(ny, nx)[:-1, :-1].ravel()
    T = np.concatenate([np.stack([k, k + 1, k + nx + 1], 1), np.stack([k, k + nx + 1, k + nx], 1)])
    return V, T
