"""PNG previews of faces: a small software renderer on matplotlib's Agg backend, and the
choice between it and the OpenGL one of :mod:`mpeg4fba.render.gl`.

No window: the meshes of a :class:`~mpeg4fba.fba.face.FaceModel` (neutral, posed or one
frame of a playback) are put through their transform chain, seen through a perspective
camera and shaded with Lambert's law (a key and a fill light): per vertex and
interpolated across the triangle ("gouraud", the default: smooth), or per triangle
("flat").  That scene is built once (``build_scene``) and drawn by one of two backends:

* "matplotlib": triangles sorted back to front (painter's algorithm) and drawn as
  collections on Agg; works wherever matplotlib does;
* "gl": the same triangles through OpenGL with a depth buffer and 4x multisampling, on
  a headless EGL context (Mesa's llvmpipe where there is no GPU): about 5x faster, and
  right where meshes interpenetrate (lips over the mouth cavity).  Needs ``moderngl``
  and the system's EGL/GL libraries (Debian: ``libegl1 libgl1 libgl1-mesa-dri``).

``render_face(..., backend="auto")`` (the default) uses GL where
:func:`~mpeg4fba.render.gl.gl_available` and falls back to matplotlib silently;
:data:`last_backend` records which one drew the last image and :data:`last_fallback`
why "auto" did not use GL.  ``backend="gl"`` raises RuntimeError (with the reason) where
GL can't work, ``backend="matplotlib"`` never tries it.  The environment variable
``MPEG4FBA_RENDER=gl`` or ``MPEG4FBA_RENDER=matplotlib`` replaces "auto" (e.g. to get
the software pictures to the bit, or to make a missing GL an error in CI).

Colours: a colour per vertex (an ``[n, 3]`` array) where ``colors`` or ``face.colors``
has one (the procedural reference head carries such arrays for its lips, brows, irises
and gums; a VRML face keeps them as Color nodes), else a colour per mesh: one
``colors`` gives, or the mesh's own (``FaceMesh.color``, a VRML face's Material), or
one picked from its name (skin, eyes, teeth, tongue, hair, mouth...:
:func:`mesh_color`).

Example
-------
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> quad = FaceMesh("Skin", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
>>> image = render_face(FaceModel([quad]), size=(64, 48))
>>> image.shape, image.dtype.name
((48, 64, 3), 'uint8')
>>> bool((image[24, 32] != image[0, 0]).any())      # the quad covers the centre
True
>>> from mpeg4fba.render import preview
>>> preview.last_backend in ("gl", "matplotlib")    # GL where it works here
True
"""
from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from .._atomic import atomic_write
from ..fba.appearance import mesh_color

__all__ = ["render_face", "render_grid", "save_png", "save_image", "IMAGE_SUFFIXES", "mesh_color",
           "VIEWS", "BACKENDS", "project_points"]

#: Camera yaw (degrees, about the face's up axis) and pitch of each named view.
VIEWS = {"front": (0.0, 0.0), "three-quarter": (35.0, 8.0), "profile": (90.0, 0.0)}

BACKGROUND = (0.93, 0.94, 0.96)
_FILL = np.array([0.35, -0.45, 0.82]) / np.linalg.norm([0.35, -0.45, 0.82])   # from below right


def _pose_arrays(face, frames, frame: int) -> dict:
    """World vertices of every mesh: neutral (None), a playback, a stream or a pose dict."""
    from ..fba.face import Playback
    from ..fba.stream import FapStream
    if frames is None:
        return {name: face.world_vertices(name) for name in face.meshes}
    if isinstance(frames, FapStream):
        frames = face.play(frames)
    elif isinstance(frames, Mapping):
        frames = face.pose(frames)
    if not isinstance(frames, Playback):
        raise TypeError("frames is None (neutral), a {fap: value} pose, a FapStream or a "
                        f"Playback, not {type(frames).__name__}")
    if not -len(frames) <= frame < len(frames):
        raise IndexError(f"frame {frame} of a playback of {len(frames)} frames")
    return {name: frames.world_vertices(name)[frame] for name in face.meshes}


def _camera(yaw: float, pitch: float) -> np.ndarray:
    """World-to-camera rotation: the camera looks at the face from ``yaw`` degrees to the
    face's left and ``pitch`` degrees above."""
    a, b = np.radians(yaw), np.radians(pitch)
    ry = np.array([[np.cos(a), 0, -np.sin(a)], [0, 1, 0], [np.sin(a), 0, np.cos(a)]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    return rx @ ry


def _vertex_normals(v: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (unit; zero for unused vertices)."""
    fn = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, tri[:, k], fn)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length > 0, length, 1.0)


#: The backends of :func:`render_face`; "auto" picks GL where it works.
BACKENDS = ("auto", "gl", "matplotlib")
#: The backend that drew the last image ("gl" or "matplotlib"; None before the first).
last_backend: Optional[str] = None
#: Why the last "auto" render did not use GL (None when it did, or was not asked to).
last_fallback: Optional[str] = None


def render_face(face, frames=None, *, frame: int = 0, size: Sequence[int] = (480, 560),
                view: Union[str, tuple] = "front", colors: Optional[Mapping] = None,
                shading: str = "gouraud", background: Sequence[float] = BACKGROUND,
                light: Sequence[float] = (-0.45, 0.55, 0.70), fit=None, cull: bool = True,
                hide: Sequence[str] = (), backend: str = "auto") -> np.ndarray:
    """Render a face to an RGB image ``[h, w, 3]`` (uint8).

    ``frames`` is None (the neutral face), a ``{fap: value}`` pose, a FapStream or a
    Playback (``frame`` picks its frame).  ``view`` is "front", "three-quarter",
    "profile" or a (yaw, pitch) pair in degrees.  ``colors`` maps mesh names to an RGB
    colour or a per-vertex ``[n, 3]`` array (default: ``face.colors`` where the face has
    them, else the mesh's own colour or one from its name).  The camera frames the
    neutral face, so poses of one face line up; ``fit`` may give the box ``(lo, hi)``
    to frame instead.  ``cull`` drops triangles facing away from the camera (meshes
    wound outward, as VRML's ``ccw TRUE``); with ``cull=False`` only closed meshes
    (:meth:`FaceMesh.is_closed`, drawn single-sided in glTF and VRML too) are culled,
    so a mouth cavity wound inward never hides the teeth; ``hide`` names meshes not to
    draw.

    ``backend``: "gl" draws with OpenGL (:mod:`mpeg4fba.render.gl`: moderngl on a
    headless EGL context, a depth buffer, 4x multisampling; RuntimeError saying why when
    it can't), "matplotlib" with the software renderer (painter's sort on Agg), "auto"
    (the default) with GL where :func:`~mpeg4fba.render.gl.gl_available` and matplotlib
    otherwise, silently; the environment variable ``MPEG4FBA_RENDER=gl|matplotlib``
    replaces "auto".  Both draw the same scene (camera, framing, colours, lights);
    :data:`last_backend` tells which one ran.
    """
    global last_backend, last_fallback
    scene = build_scene(face, frames, frame, size, view, colors, shading, background, light,
                        fit, cull, hide)
    chosen, why = _choose_backend(backend)
    if chosen == "gl":
        from . import gl
        try:
            image = gl._draw(scene)
        except gl.GLRenderError as exc:
            if backend != "auto" or _env_backend():
                raise
            why = str(exc)      # e.g. an image larger than the driver's framebuffers
        else:
            last_backend, last_fallback = "gl", None
            return image
    image = _draw_agg(scene)
    last_backend, last_fallback = "matplotlib", why
    return image


def _env_backend() -> str:
    """The backend ``MPEG4FBA_RENDER`` asks for in place of "auto" ("" when unset)."""
    env = os.environ.get("MPEG4FBA_RENDER", "").strip().lower()
    if env not in ("", *BACKENDS):
        raise ValueError(f"MPEG4FBA_RENDER is one of {', '.join(BACKENDS)}, not {env!r}")
    return "" if env == "auto" else env


def _choose_backend(backend: str) -> tuple:
    """``(backend to run, why "auto" is not using GL or None)``; RuntimeError when GL is
    demanded (``backend="gl"`` or ``MPEG4FBA_RENDER=gl``) and can't work."""
    if backend not in BACKENDS:
        raise ValueError(f"backend is one of {', '.join(BACKENDS)}, not {backend!r}")
    if backend == "auto":
        backend = _env_backend() or "auto"
    if backend == "matplotlib":
        return "matplotlib", None
    from . import gl                  # looked up at each call: tests monkeypatch it
    ok, reason = gl.gl_available()
    if ok:
        return "gl", None
    if backend == "gl":
        raise RuntimeError(f"OpenGL rendering is not available: {reason}")
    return "matplotlib", reason


@dataclass
class Scene:
    """A face made ready to draw, the same for every backend: the triangles to draw
    (culled, hidden meshes left out) as projected corners ``polys`` [m, 3, 2] on the
    image plane (+y up; the image spans ``-half_w..half_w`` by ``-half_h..half_h``),
    each corner's distance from the camera along its axis ``depths`` [m, 3] and its lit
    RGB colour ``colors`` [m, 3, 3] (0-1)."""

    width: int
    height: int
    half_w: float
    half_h: float
    shading: str
    background: tuple
    polys: np.ndarray
    depths: np.ndarray
    colors: np.ndarray


def _framing(face, size: Sequence[int], view, fit) -> tuple:
    """The camera of :func:`render_face`: ``(w, h, R, centre, dist, half_w, half_h)``,
    the image size, the world-to-camera rotation, the point looked at, the camera's
    distance from it and the half extents of the image plane."""
    w, h = (int(s) for s in size)
    if w < 1 or h < 1:
        raise ValueError(f"size is (width, height) in pixels, not {tuple(size)}")
    if isinstance(view, str):
        if view not in VIEWS:
            raise ValueError(f"view is one of {', '.join(VIEWS)} or (yaw, pitch), not {view!r}")
        yaw, pitch = VIEWS[view]
    else:
        yaw, pitch = (float(a) for a in view)
    R = _camera(yaw, pitch)
    # Frame the neutral face (all meshes), seen from this camera.
    if fit is None:
        neutral = np.concatenate([face.world_vertices(m) for m in face.meshes
                                  if len(face.meshes[m].vertices)] or [np.zeros((1, 3))])
        lo, hi = neutral.min(axis=0), neutral.max(axis=0)
    else:
        lo, hi = (np.asarray(b, float) for b in fit)
    centre = (lo + hi) / 2
    corners = np.array(np.meshgrid(*zip(lo, hi))).reshape(3, -1).T
    cam_pts = (corners - centre) @ R.T
    radius = float(np.linalg.norm(hi - lo)) / 2 or 1.0
    dist = 3.2 * radius
    proj_box = cam_pts[:, :2] * (dist / (dist - cam_pts[:, 2]))[:, None]
    half = np.abs(proj_box).max(axis=0) * 1.06
    aspect = w / h
    half_w, half_h = max(half[0], half[1] * aspect), max(half[1], half[0] / aspect)
    return w, h, R, centre, dist, float(half_w), float(half_h)


def project_points(face, points, *, size: Sequence[int] = (480, 560),
                   view: Union[str, tuple] = "front", fit=None) -> np.ndarray:
    """Where world points ``[n, 3]`` fall in the image :func:`render_face` draws with
    the same ``size``, ``view`` and ``fit``: ``[n, 3]`` rows of (column, row, distance
    from the camera along its axis), in pixels from the top left corner.

    >>> from mpeg4fba.fba.face import FaceMesh, FaceModel
    >>> quad = FaceMesh("Skin", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    >>> project_points(FaceModel([quad]), [[0, 0, 0]], size=(64, 48))[0, :2].tolist()
    [32.0, 24.0]
    """
    w, h, R, centre, dist, half_w, half_h = _framing(face, size, view, fit)
    v = (np.asarray(points, dtype=float).reshape(-1, 3) - centre) @ R.T
    depth = dist - v[:, 2]
    proj = v[:, :2] * (dist / np.where(depth > 0, depth, np.nan))[:, None]
    col = (proj[:, 0] + half_w) / (2 * half_w) * w
    row = (half_h - proj[:, 1]) / (2 * half_h) * h
    return np.stack([col, row, depth], axis=1)


def build_scene(face, frames, frame: int, size: Sequence[int], view,
                colors: Optional[Mapping], shading: str, background: Sequence[float],
                light: Sequence[float], fit, cull: bool, hide: Sequence[str]) -> Scene:
    """Check the arguments of :func:`render_face` and build its :class:`Scene`: the
    camera, the framing, the culling and the lighting (per corner) shared by both
    renderers."""
    w, h, R, centre, dist, half_w, half_h = _framing(face, size, view, fit)
    if shading not in ("gouraud", "flat"):
        raise ValueError(f"shading is 'gouraud' or 'flat', not {shading!r}")
    world = _pose_arrays(face, frames, frame)
    palette = dict(getattr(face, "colors", None) or {})
    palette.update(colors or {})
    light_dir = np.asarray(light, float)
    light_dir = light_dir / np.linalg.norm(light_dir)
    light_cam = light_dir           # given in the camera frame: every view is lit alike
    polys, shades, depths = [], [], []
    for name, mesh in face.meshes.items():
        if name in hide or not len(mesh.triangles):
            continue
        v = (world[name] - centre) @ R.T                         # camera frame, +z to viewer
        tri = mesh.triangles
        fn = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
        fl = np.linalg.norm(fn, axis=1)
        ok = fl > 0
        fn = fn / np.where(ok, fl, 1.0)[:, None]
        depth = dist - v[:, 2]                                    # distance along the axis
        if (depth <= 0).any():
            raise ValueError("the camera is inside the face; give a larger fit box")
        proj = v[:, :2] * (dist / depth)[:, None]                 # perspective divide
        # facing the camera: the projected triangle turns counter-clockwise
        p = proj[tri]
        area = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        # Closed meshes are single-sided everywhere (glTF, VRML): their back faces are
        # never meant to be seen, and the inward-wound mouth cavity would cover the teeth.
        single = cull or mesh.is_closed()
        keep = ok & (area > 0) if single else ok
        if not keep.any():
            continue
        col = np.asarray(palette.get(name, mesh.display_color()), dtype=float)
        vcol = np.broadcast_to(col[:3], (len(v), 3)) if col.ndim == 1 else col[:, :3]
        if shading == "gouraud":
            vn = _vertex_normals(v, tri)
            lam = vn @ light_cam
            lam = np.abs(lam) if not single else np.clip(lam, 0.0, 1.0)
            fill = np.clip(vn @ _FILL, 0.0, 1.0)
            lit = vcol * (0.30 + 0.58 * lam + 0.22 * fill)[:, None]
            spec = np.clip(vn @ _half_vector(light_cam), 0, 1) ** 24 * 0.08
            corner = np.clip(lit + spec[:, None], 0, 1)[tri]      # [m, 3, 3]
        else:
            lam = np.clip(np.abs(fn @ light_cam) if not single else fn @ light_cam, 0, 1)
            fill = np.clip(fn @ _FILL, 0.0, 1.0)
            flat = vcol[tri].mean(axis=1) * (0.30 + 0.58 * lam + 0.22 * fill)[:, None]
            corner = np.repeat(flat[:, None, :], 3, axis=1)
        polys.append(p[keep])
        shades.append(corner[keep])
        depths.append(depth[tri[keep]])
    return Scene(w, h, float(half_w), float(half_h), shading, tuple(background),
                  np.concatenate(polys) if polys else np.zeros((0, 3, 2)),
                  np.concatenate(depths) if depths else np.zeros((0, 3)),
                  np.concatenate(shades) if shades else np.zeros((0, 3, 3)))


def _draw_agg(scene: Scene) -> np.ndarray:
    """The software renderer: the scene's triangles sorted back to front (painter's
    algorithm) and drawn on matplotlib's Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    w, h = scene.width, scene.height
    fig = Figure(figsize=(w / 100.0, h / 100.0), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    fig.patch.set_facecolor(scene.background)
    ax.set_xlim(-scene.half_w, scene.half_w)
    ax.set_ylim(-scene.half_h, scene.half_h)
    if len(scene.polys):
        order = np.argsort(-scene.depths.mean(axis=1), kind="stable")    # far ones first
        P, C = scene.polys[order], scene.colors[order]
        if scene.shading == "gouraud":
            _gouraud(ax, P, C)
        else:
            coll = PolyCollection(P, facecolors=C[:, 0], edgecolors=C[:, 0],
                                  linewidths=0.3, antialiaseds=False)
            ax.add_collection(coll)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
    return image


def _gouraud(ax, P: np.ndarray, C: np.ndarray) -> None:
    """Draw triangles ``P`` [m, 3, 2] in order with colours ``C`` [m, 3, 3] interpolated
    across each (Agg's Gouraud triangles), after a thin flat outline of each that hides
    the hairline cracks between neighbours."""
    from matplotlib.collections import PolyCollection, TriMesh
    from matplotlib.tri import Triangulation

    m = len(P)
    mean = C.mean(axis=1)
    ax.add_collection(PolyCollection(P, facecolors=mean, edgecolors=mean, linewidths=0.6,
                                     antialiaseds=False, zorder=1))
    # chunks keep the painter's order within and between them
    for k0 in range(0, m, 20000):
        k1 = min(m, k0 + 20000)
        xy = P[k0:k1].reshape(-1, 2)
        tri = Triangulation(xy[:, 0], xy[:, 1], np.arange(len(xy)).reshape(-1, 3))
        mesh = TriMesh(tri, zorder=2 + k0 / m)
        rgba = np.concatenate([C[k0:k1].reshape(-1, 3), np.ones((len(xy), 1))], axis=1)
        mesh.set_facecolor(rgba)
        mesh.set_edgecolor("none")
        ax.add_collection(mesh)


def _half_vector(light: np.ndarray) -> np.ndarray:
    hv = light + np.array([0.0, 0.0, 1.0])
    return hv / np.linalg.norm(hv)


def render_grid(images: Sequence[np.ndarray], labels: Optional[Sequence[str]] = None,
                cols: int = 4, *, background: Sequence[float] = (1.0, 1.0, 1.0),
                label_size: float = 11.0) -> np.ndarray:
    """Tile images (all of one size) in ``cols`` columns, each with its label below it,
    into one RGB image.

    >>> tile = np.zeros((20, 30, 3), np.uint8)
    >>> render_grid([tile, tile, tile], ["a", "b", "c"], cols=2).shape[:2]
    (80, 60)
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if not len(images):
        raise ValueError("no images to tile")
    h, w = images[0].shape[:2]
    if any(im.shape[:2] != (h, w) for im in images):
        raise ValueError("the images of a grid must all have one size")
    labels = list(labels) if labels is not None else [""] * len(images)
    if len(labels) != len(images):
        raise ValueError(f"{len(labels)} labels for {len(images)} images")
    cols = max(1, min(int(cols), len(images)))
    rows = -(-len(images) // cols)
    label_h = int(round(label_size * 1.8)) if any(labels) else 0
    W, H = cols * w, rows * (h + label_h)
    fig = Figure(figsize=(W / 100.0, H / 100.0), dpi=100)
    canvas = FigureCanvasAgg(fig)
    fig.patch.set_facecolor(tuple(background))
    for k, (im, text) in enumerate(zip(images, labels)):
        r, c = divmod(k, cols)
        top = 1.0 - r * (h + label_h) / H
        ax = fig.add_axes((c * w / W, top - h / H, w / W, h / H))
        ax.imshow(im, interpolation="nearest")
        ax.set_axis_off()
        if text:
            fig.text((c + 0.5) * w / W, top - (h + label_h * 0.55) / H, text, ha="center",
                     va="center", fontsize=label_size, color=(0.1, 0.1, 0.1))
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


#: The picture files :func:`save_image` writes, by the name's ending (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


def _checked(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] not in (3, 4):
        raise ValueError(f"an image is [h, w, 3] or [h, w, 4], not {image.shape}")
    return image


def _png_bytes(image: np.ndarray) -> bytes:
    from matplotlib import image as mimage

    buffer = io.BytesIO()
    mimage.imsave(buffer, image, format="png")
    return buffer.getvalue()


def _jpeg_bytes(image: np.ndarray, quality: int) -> bytes:
    from PIL import Image

    if image.dtype != np.uint8:
        image = np.clip(np.asarray(image, float) * 255 + 0.5, 0, 255).astype(np.uint8)
    if image.shape[2] == 4:  # JPEG has no alpha: lay the picture on white
        a = image[:, :, 3:].astype(float) / 255
        image = np.round(image[:, :, :3] * a + 255 * (1 - a)).astype(np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(buffer, format="JPEG", quality=quality)
    return buffer.getvalue()


def save_png(path: Union[str, os.PathLike], image: np.ndarray) -> Path:
    """Write an RGB(A) uint8 image as PNG, atomically (a temporary file beside it, then a
    rename), and return the path.

    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = save_png(os.path.join(d, "x.png"), np.zeros((4, 5, 3), np.uint8))
    ...     p.read_bytes()[:4]
    b'\\x89PNG'
    """
    path = Path(path)
    data = _png_bytes(_checked(image))
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, data)
    return path


def save_image(path: Union[str, os.PathLike], image: np.ndarray, *, quality: int = 92) -> Path:
    """Write an RGB(A) uint8 image as PNG (``.png``) or JPEG (``.jpg``, ``.jpeg``; any
    alpha laid on white), by the name's ending, atomically; return the path.  ValueError
    for another ending: never one format's bytes under another's name.

    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = save_image(os.path.join(d, "x.JPG"), np.zeros((4, 5, 3), np.uint8))
    ...     p.read_bytes()[:3]
    b'\\xff\\xd8\\xff'
    """
    path = Path(path)
    low = path.name.lower()
    if not low.endswith(IMAGE_SUFFIXES):
        raise ValueError(f"{os.fspath(path)}: a picture is written as "
                         f"{', '.join(IMAGE_SUFFIXES)} (the name's ending says which)")
    image = _checked(image)
    data = _png_bytes(image) if low.endswith(".png") else _jpeg_bytes(image, quality)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, data)
    return path
