"""OpenGL previews of faces without a GPU or a window: moderngl on a headless EGL context.

Where no GPU is present, Mesa's llvmpipe rasterises on the CPU, still an order of
magnitude faster than the matplotlib renderer of :mod:`mpeg4fba.render.preview`; it
needs the ``moderngl`` wheel and the system's EGL, GL and Mesa DRI libraries (Debian:
``libegl1 libgl1 libgl1-mesa-dri``).  :func:`gl_available` says whether it works here
and, if not, why.

The picture is the software renderer's: the scene (camera, framing of the neutral face,
culling, colours, Lambert and fill lights per vertex) is built once by
``preview.build_scene`` and only drawn here, with a depth buffer in place of the painter's
sort and 4x multisampling in place of Agg's antialiasing.  Corners are lit on the CPU
(numpy, the one lighting formula for both backends, so they can't drift apart) and their
colours interpolated across each triangle in screen space (``noperspective``), as Agg's
Gouraud triangles do.  One context per process, made on first use and kept: making it
is the slow part (about half a second), a frame then takes milliseconds.

Example
-------
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> from mpeg4fba.render.preview import render_face
>>> ok, reason = gl_available()
>>> isinstance(ok, bool) and bool(reason)
True
>>> quad = FaceMesh("Skin", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
>>> try:
...     image = render_face_gl(FaceModel([quad]), size=(64, 48))
... except RuntimeError:                     # no GL here: the message says why
...     image = render_face(FaceModel([quad]), size=(64, 48), backend="matplotlib")
>>> image.shape, bool((image[24, 32] != image[0, 0]).any())
((48, 64, 3), True)
"""
from __future__ import annotations

import os
import threading
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from .preview import BACKGROUND, Scene, build_scene

__all__ = ["gl_available", "render_face_gl", "GLRenderError"]

#: Samples per pixel asked for (fewer where the driver has fewer; none at all is fine).
SAMPLES = 4

_VERTEX_SHADER = """
#version 330
in vec3 in_pos;                 // normalised device coordinates, computed in numpy
in vec3 in_color;
noperspective out vec3 color;   // screen-space interpolation, as Agg's Gouraud triangles
void main() {
    gl_Position = vec4(in_pos, 1.0);
    color = in_color;
}
"""
_FRAGMENT_SHADER = """
#version 330
noperspective in vec3 color;
out vec4 frag;
void main() {
    frag = vec4(color, 1.0);
}
"""


class GLRenderError(RuntimeError):
    """GL is up but could not draw this image (e.g. larger than the driver's buffers)."""


class _Renderer:
    """The process's GL context, its shader program and the framebuffers of the last
    image size (an animation renders many frames of one size)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.lock = threading.Lock()        # one context: one draw at a time
        self.prog = ctx.program(vertex_shader=_VERTEX_SHADER, fragment_shader=_FRAGMENT_SHADER)
        self.samples = min(SAMPLES, int(ctx.max_samples or 0))
        self.samples = self.samples if self.samples > 1 else 0
        info = ctx.info
        self.max_size = min(int(info.get("GL_MAX_RENDERBUFFER_SIZE", 4096)),
                            *(int(d) for d in np.ravel(info.get("GL_MAX_VIEWPORT_DIMS", 4096))))
        self.name = f"{info.get('GL_RENDERER', '?')}, OpenGL {info.get('GL_VERSION', '?')}"
        self._size: Optional[tuple] = None
        self._buffers: list = []
        self._fbos: tuple = ()

    def _framebuffers(self, w: int, h: int) -> tuple:
        """``(draw, resolve)``: the multisampled framebuffer drawn into and the plain one
        it is resolved into and read from (the same one without multisampling)."""
        if self._size != (w, h):
            for obj in self._buffers:
                obj.release()
            self._size, self._buffers, self._fbos = None, [], ()   # until remade whole
            ctx = self.ctx
            color = ctx.renderbuffer((w, h), 4, samples=self.samples)
            depth = ctx.depth_renderbuffer((w, h), samples=self.samples)
            draw = ctx.framebuffer(color_attachments=[color], depth_attachment=depth)
            self._buffers = [draw, color, depth]
            resolve = draw
            if self.samples:
                plain = ctx.renderbuffer((w, h), 4)
                resolve = ctx.framebuffer(color_attachments=[plain])
                self._buffers += [resolve, plain]
            self._size, self._fbos = (w, h), (draw, resolve)
        return self._fbos

    def draw(self, scene: Scene) -> np.ndarray:
        import moderngl

        w, h = scene.width, scene.height
        if max(w, h) > self.max_size:
            raise GLRenderError(f"{w}x{h} pixels is larger than this GL's framebuffers "
                                f"({self.max_size} at most)")
        data = _vertices(scene)
        with self.lock:
            try:
                with self.ctx:                      # current on this thread
                    return self._draw(scene, data, moderngl)
            except moderngl.Error as exc:
                raise GLRenderError(f"OpenGL failed to draw: {exc}") from exc

    def _draw(self, scene: Scene, data: np.ndarray, moderngl) -> np.ndarray:
        ctx, (w, h) = self.ctx, (scene.width, scene.height)
        draw, resolve = self._framebuffers(w, h)
        draw.use()
        ctx.viewport = (0, 0, w, h)
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)   # culled in numpy, as in software
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        r, g, b = (float(c) for c in scene.background[:3])
        draw.clear(r, g, b, 1.0, depth=1.0)
        if len(data):
            vbo = ctx.buffer(data.tobytes())
            vao = ctx.vertex_array(self.prog, [(vbo, "3f 3f", "in_pos", "in_color")])
            try:
                vao.render(moderngl.TRIANGLES)
            finally:
                vao.release()
                vbo.release()
        if resolve is not draw:
            ctx.copy_framebuffer(resolve, draw)              # resolves the samples
        raw = resolve.read(components=3, alignment=1)
        # GL's rows run bottom to top; images run top to bottom
        return np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1].copy()


def _vertices(scene: Scene) -> np.ndarray:
    """Interleaved ``[3m, 6]`` float32 vertices (x, y, z in normalised device
    coordinates; r, g, b) of the scene's triangles.  z is affine in 1 / depth, as a
    perspective projection's is, so it interpolates linearly across the screen."""
    if not len(scene.polys):
        return np.zeros((0, 6), np.float32)
    d = scene.depths.reshape(-1)
    near, far = float(d.min()) * 0.999, float(d.max()) * 1.001   # strictly inside the clip
    inv_near, inv_far = 1.0 / near, 1.0 / far
    out = np.empty((len(d), 6), np.float32)
    out[:, 0] = scene.polys[:, :, 0].reshape(-1) / scene.half_w
    out[:, 1] = scene.polys[:, :, 1].reshape(-1) / scene.half_h
    out[:, 2] = 2.0 * (inv_near - 1.0 / d) / (inv_near - inv_far) - 1.0
    out[:, 3:] = scene.colors.reshape(-1, 3)
    return out


# pid -> (available, reason, renderer): a forked child makes its own context
_state: dict = {}
_state_lock = threading.Lock()


def _library(name: str, fallback: str) -> Optional[str]:
    """The shared library ``name`` (EGL, GL) that loads here, or None."""
    import ctypes
    from ctypes.util import find_library

    for lib in dict.fromkeys((find_library(name), fallback)):
        if lib:
            try:
                ctypes.CDLL(lib)
                return lib
            except OSError:
                pass
    return None


def _create() -> tuple:
    """``(available, reason, renderer or None)``: a context and a self-test draw."""
    try:
        import moderngl
    except ImportError as exc:
        return False, f"moderngl is not installed ({exc}); pip install moderngl", None
    apt = "on Debian: apt-get install libegl1 libgl1 libgl1-mesa-dri"
    libegl = _library("EGL", "libEGL.so.1")
    if libegl is None:
        return False, f"no EGL library (libEGL.so.1) found; {apt}", None
    libgl = _library("GL", "libGL.so.1")
    if libgl is None:
        return False, f"no GL library (libGL.so.1) found; {apt}", None
    try:
        # glcontext finds the libraries itself but wants the development links
        # (libEGL.so); pass the runtime ones found above
        ctx = moderngl.create_standalone_context(backend="egl", libegl=libegl, libgl=libgl)
    except Exception as exc:        # glcontext raises bare Exceptions for EGL failures
        return False, f"EGL context creation failed ({type(exc).__name__}: {exc}); {apt}", None
    try:
        renderer = _Renderer(ctx)
        _self_test(renderer)
    except Exception as exc:
        ctx.release()
        return False, f"OpenGL context made but unusable ({type(exc).__name__}: {exc})", None
    samples = f"{renderer.samples}x multisampling" if renderer.samples else "no multisampling"
    return True, f"EGL: {renderer.name}, {samples}", renderer


def _self_test(renderer: _Renderer) -> None:
    """Two screen-filling triangles, the far one drawn last: the near one's colour must
    win (the depth buffer works) and come back in the right place and order."""
    polys = np.array([[[-2, -2], [4, -2], [-2, 4]]] * 2, float)
    depths = np.array([[1.0] * 3, [2.0] * 3])
    colors = np.array([[[0.0, 1.0, 0.0]] * 3, [[1.0, 0.0, 0.0]] * 3])
    image = renderer.draw(Scene(8, 6, 1.0, 1.0, "gouraud", (0.0, 0.0, 1.0), polys, depths,
                                colors))
    if image.shape != (6, 8, 3) or image[3, 4].tolist() != [0, 255, 0]:
        raise RuntimeError(f"self-test drew {image[3, 4].tolist()} where [0, 255, 0] belongs")


def _renderer() -> tuple:
    pid = os.getpid()
    with _state_lock:
        if pid not in _state:
            if any(r is not None for _, _, r in _state.values()):
                # Mesa's EGL hangs in a child forked after the parent made a context,
                # both with the parent's context and with a new one
                _state[pid] = (False, "forked from a process that made an OpenGL context, "
                               "which Mesa can't use or remake after fork(); render in "
                               "the parent or start workers with 'spawn'", None)
            else:
                _state[pid] = _create()
        return _state[pid]


def _after_fork_in_child() -> None:
    global _state_lock
    _state_lock = threading.Lock()      # another thread may have held it at the fork


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def gl_available() -> tuple:
    """``(True, what draws)`` where OpenGL rendering works here, else ``(False, why
    not)``: no moderngl, no EGL or GL library, no context, a failed self-test.  Tried
    once per process (the context made is kept for every later render).

    >>> ok, reason = gl_available()
    >>> ok in (True, False) and isinstance(reason, str)
    True
    """
    ok, reason, _ = _renderer()
    return ok, reason


def _draw(scene: Scene) -> np.ndarray:
    """Draw a prepared scene; RuntimeError (why) when GL is unavailable."""
    ok, reason = gl_available()         # looked up at each call: tests monkeypatch it
    if not ok:
        raise RuntimeError(f"OpenGL rendering is not available: {reason}")
    return _renderer()[2].draw(scene)


def render_face_gl(face, frames=None, *, frame: int = 0, size: Sequence[int] = (480, 560),
                   view: Union[str, tuple] = "front", colors: Optional[Mapping] = None,
                   shading: str = "gouraud", background: Sequence[float] = BACKGROUND,
                   light: Sequence[float] = (-0.45, 0.55, 0.70), fit=None, cull: bool = True,
                   hide: Sequence[str] = ()) -> np.ndarray:
    """:func:`~mpeg4fba.render.preview.render_face` drawn with OpenGL: the same
    arguments, the same picture (to within antialiasing and the depth buffer's handling
    of overlaps); RuntimeError saying why when GL is not available here.

    >>> ok, _ = gl_available()
    >>> from mpeg4fba.fba.face import FaceMesh, FaceModel
    >>> tri = FaceMesh("Tongue", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> (render_face_gl(FaceModel([tri]), size=(40, 30)).shape if ok else (30, 40, 3))
    (30, 40, 3)
    """
    scene = build_scene(face, frames, frame, size, view, colors, shading, background, light,
                        fit, cull, hide)
    return _draw(scene)
