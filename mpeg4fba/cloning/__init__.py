"""Facial motion cloning (Pandzic, "Facial Motion Cloning").

So far: interpolation of function values from a 2D triangle mesh, with the
paper's anti-aliasing filter (:mod:`mpeg4fba.cloning.interp2d`).
"""
from __future__ import annotations

from .interp2d import antialiased_weights, interpolate, interpolation_weights

__all__ = ["interpolation_weights", "interpolate", "antialiased_weights"]
