"""Pictures of faces: PNG previews rendered with matplotlib (no OpenGL needed).

>>> from mpeg4fba.render import render_face, render_grid, save_png
"""
from .preview import VIEWS, mesh_color, render_face, render_grid, save_png

__all__ = ["render_face", "render_grid", "save_png", "mesh_color", "VIEWS"]
