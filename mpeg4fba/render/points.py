"""A picture of a face's feature points: front and side views, each point a dot coloured
by its confidence and labelled with its id.

The face is drawn by :func:`~mpeg4fba.render.preview.render_face` (OpenGL where it works,
matplotlib otherwise) and the points are projected with the same camera
(:func:`~mpeg4fba.render.preview.project_points`).  A point hidden from a view by the
face (the far side in profile, teeth and tongue behind the lips) is a hollow ring
without a label.  Colours: confidence 0 red, 0.5 yellow, 1 green
(:func:`confidence_color`, the same as the point editor's); blue for a point with no
confidence given.

Example
-------
>>> import tempfile, os
>>> from mpeg4fba.models import reference_head
>>> face = reference_head(resolution=0.5)
>>> with tempfile.TemporaryDirectory() as d:
...     p = render_points(face, face.points, os.path.join(d, "points.png"),
...                       confidences={"2.1": 0.2}, size=(600, 400))
...     p.name, p.read_bytes()[:4], os.listdir(d)
('points.png', b'\\x89PNG', ['points.png'])
"""
from __future__ import annotations

import colorsys
import os
from pathlib import Path
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from ..fba.featurepoints import FeaturePointSet, normalise_id
from .preview import project_points, render_face, save_png

__all__ = ["render_points", "points_image", "confidence_color", "NO_CONFIDENCE", "upright"]

#: The colour of a point given without a confidence (RGB, 0-1).
NO_CONFIDENCE = (0x3D / 255, 0x8B / 255, 0xFD / 255)
_LEGEND_H = 44


def confidence_color(confidence: Optional[float]) -> tuple:
    """RGB (0-1) of a confidence: hue 120 x confidence degrees (red 0, yellow 0.5, green
    1) at 80 % saturation and 45 % lightness, as CSS ``hsl()``; None gives
    :data:`NO_CONFIDENCE`.

    >>> [round(c, 3) for c in confidence_color(0)], [round(c, 3) for c in confidence_color(1)]
    ([0.81, 0.09, 0.09], [0.09, 0.81, 0.09])
    """
    if confidence is None:
        return NO_CONFIDENCE
    c = min(max(float(confidence), 0.0), 1.0)
    return colorsys.hls_to_rgb(c / 3.0, 0.45, 0.80)


def _hidden(face, at: np.ndarray, view, size, eps: float) -> np.ndarray:
    """Which points (``at``: their column, row and depth in the view) a triangle of the
    face covers nearer the camera by more than ``eps``: each triangle projected with the
    same camera, its depth at the point interpolated as 1/depth (exact in perspective)."""
    tris = [face.world_vertices(n)[m.triangles] for n, m in face.meshes.items()
            if len(m.vertices) and len(m.triangles)]
    out = np.zeros(len(at), dtype=bool)
    if not tris or not len(at):
        return out
    T = project_points(face, np.concatenate(tris).reshape(-1, 3), size=size,
                       view=view).reshape(-1, 3, 3)            # [m, corner, (col, row, depth)]
    x0, y0 = T[:, 0, 0], T[:, 0, 1]
    ax, ay = T[:, 1, 0] - x0, T[:, 1, 1] - y0
    bx, by = T[:, 2, 0] - x0, T[:, 2, 1] - y0
    det = ax * by - ay * bx
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    inv_depth = 1.0 / T[:, :, 2]
    for i, (x, y, z) in enumerate(at):
        px, py = x - x0, y - y0
        l1 = (px * by - py * bx) * inv
        l2 = (ax * py - ay * px) * inv
        l0 = 1.0 - l1 - l2
        inside = ok & (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
        if not inside.any():
            continue
        near = 1.0 / (l0[inside] * inv_depth[inside, 0] + l1[inside] * inv_depth[inside, 1]
                      + l2[inside] * inv_depth[inside, 2])
        out[i] = bool((near < z - eps).any())
    return out


def points_image(face, points: FeaturePointSet, *, confidences: Optional[Mapping] = None,
                 size: Sequence[int] = (1200, 760), views: Sequence = ("front", "profile"),
                 labels: bool = True, backend: str = "auto") -> np.ndarray:
    """The picture :func:`render_points` writes, as an RGB image ``[h, w, 3]`` (uint8):
    ``views`` side by side (names of :data:`~mpeg4fba.render.preview.VIEWS` or (yaw,
    pitch) pairs) above a legend.  Points tied to a vertex and given no position are
    placed on it.

    >>> from mpeg4fba.models import reference_head
    >>> face = reference_head(resolution=0.5)
    >>> points_image(face, face.points, size=(400, 300)).shape
    (300, 400, 3)
    """
    from matplotlib import patheffects
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    W, H = (int(s) for s in size)
    views = list(views)
    if not views:
        raise ValueError("no views to draw")
    vw, vh = W // len(views), H - _LEGEND_H
    if vw < 8 or vh < 8:
        raise ValueError(f"size {tuple(size)} is too small for {len(views)} views and a legend")
    world = {n: face.world_vertices(n) for n in face.meshes}
    resolved = points.resolve(world)
    ids = list(resolved)
    conf = {normalise_id(k): v for k, v in (confidences or {}).items()}
    unknown = [k for k in conf if k not in resolved]
    if unknown:
        raise ValueError(f"confidences for points not given: {', '.join(unknown)}")
    xyz = resolved.positions
    colours = np.array([confidence_color(conf.get(fp)) for fp in ids]).reshape(-1, 3)
    every = np.concatenate([w for w in world.values() if len(w)] or [np.zeros((1, 3))])
    scale = float(np.linalg.norm(every.max(axis=0) - every.min(axis=0))) or 1.0

    fig = Figure(figsize=(W / 100.0, H / 100.0), dpi=100)
    canvas = FigureCanvasAgg(fig)
    fig.patch.set_facecolor((0.93, 0.94, 0.96))
    outline = [patheffects.withStroke(linewidth=2.0, foreground=(0.1, 0.1, 0.1))]
    for k, view in enumerate(views):
        image = render_face(face, size=(vw, vh), view=view, backend=backend)
        ax = fig.add_axes((k * vw / W, _LEGEND_H / H, vw / W, vh / H))
        ax.imshow(image, interpolation="nearest", extent=(0, vw, vh, 0))
        ax.set_xlim(0, vw)
        ax.set_ylim(vh, 0)
        ax.set_axis_off()
        if not ids:
            continue
        at = project_points(face, xyz, size=(vw, vh), view=view)
        hidden = _hidden(face, at, view, (vw, vh), 0.004 * scale)
        seen = ~hidden
        dot = max(3.0, min(vw, vh) / 110.0)
        ax.scatter(at[hidden, 0], at[hidden, 1], s=(dot * 0.72) ** 2 * 4, facecolors="none",
                   edgecolors=colours[hidden], linewidths=1.2, zorder=3)
        ax.scatter(at[seen, 0], at[seen, 1], s=(dot * 0.72) ** 2 * 4, c=colours[seen],
                   edgecolors=(0.1, 0.1, 0.1), linewidths=0.6, zorder=4)
        if labels:
            font = max(5.0, min(8.0, min(vw, vh) / 80.0))
            for j in np.flatnonzero(seen):
                ax.text(at[j, 0] + dot * 0.8, at[j, 1] - dot * 0.6, ids[j], fontsize=font,
                        color="white", ha="left", va="bottom", zorder=5, path_effects=outline,
                        clip_on=True)
    _legend(fig, W, H)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def _legend(fig, W: int, H: int) -> None:
    """The strip below the views: the confidence scale, no confidence, hidden."""
    ax = fig.add_axes((0, 0, 1, _LEGEND_H / H))
    ax.set_xlim(0, W)
    ax.set_ylim(_LEGEND_H, 0)
    ax.set_axis_off()
    x0, x1, y = 110.0, 110.0 + min(260.0, W * 0.3), _LEGEND_H / 2
    # a narrow picture puts the markers on a second row (the whole strip needs ~650 px)
    two_rows = W < 650
    if two_rows:
        y, y2, xm = _LEGEND_H * 0.3, _LEGEND_H * 0.72, 30.0
    else:
        y2, xm = y, x1 + 40
    ramp = np.array([[confidence_color(c) for c in np.linspace(0, 1, 64)]])
    ax.imshow(ramp, extent=(x0, x1, y + 6, y - 6), aspect="auto", interpolation="bilinear")
    text = dict(fontsize=9, color=(0.15, 0.15, 0.15), va="center")
    ax.text(x0 - 8, y, "confidence 0", ha="right", **text)
    ax.text(x1 + 8, y, "1", ha="left", **text)
    ax.scatter([xm], [y2], s=50, c=[NO_CONFIDENCE], edgecolors=(0.1, 0.1, 0.1), linewidths=0.6)
    ax.text(xm + 10, y2, "no confidence given", ha="left", **text)
    ax.scatter([xm + 160], [y2], s=50, facecolors="none", edgecolors=[(0.3, 0.3, 0.3)],
               linewidths=1.2)
    ax.text(xm + 170, y2, "hidden in this view", ha="left", **text)


def render_points(face, points: FeaturePointSet, path: Union[str, os.PathLike], *,
                  confidences: Optional[Mapping] = None, size: Sequence[int] = (1200, 760),
                  **kw) -> Path:
    """Write :func:`points_image` as a PNG, atomically (a temporary file beside it, then
    a rename); return the path.  ``kw``: ``views``, ``labels``, ``backend``."""
    image = points_image(face, points, confidences=confidences, size=size, **kw)
    return save_png(path, image)


def upright(face, points, up, forward) -> tuple:
    """(face, points) turned so that the head found looks down +z with +y up, as the
    pictures are drawn (a head with +Z up or facing +X is shown from the front too)."""
    if up is None or forward is None:
        return face, points
    from ..fba.face import FaceMesh, FaceModel

    up = np.asarray(up, float) / np.linalg.norm(up)
    forward = np.asarray(forward, float) - np.dot(forward, up) * up
    forward /= np.linalg.norm(forward)
    R = np.array([np.cross(up, forward), up, forward])      # rows: the face's left, up, forward
    if np.allclose(R, np.eye(3)):
        return face, points
    meshes = [FaceMesh(n, face.world_vertices(n) @ R.T, m.triangles, color=m.color)
              for n, m in face.meshes.items()]
    turned = FaceModel(meshes, name=face.name)
    turned.colors = dict(face.colors)
    M = np.eye(4)
    M[:3, :3] = R
    return turned, points.transformed(M)
