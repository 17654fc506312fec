"""Pictures of faces: PNG previews drawn with OpenGL where it works headless (moderngl on
EGL, no GPU needed) and with matplotlib otherwise; see :func:`render_face`.

>>> from mpeg4fba.render import render_face, render_grid, save_png
"""
from .gl import gl_available, render_face_gl
from .preview import BACKENDS, VIEWS, mesh_color, render_face, render_grid, save_png

__all__ = ["render_face", "render_grid", "save_png", "mesh_color", "VIEWS", "BACKENDS",
           "gl_available", "render_face_gl"]
