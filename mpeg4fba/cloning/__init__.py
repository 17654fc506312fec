"""Facial motion cloning (Pandzic, "Facial Motion Cloning").

So far: interpolation of function values from a 2D triangle mesh, with the
paper's anti-aliasing filter (:mod:`mpeg4fba.cloning.interp2d`).
"""
from __future__ import annotations

from .interp2d import antialiased_weights, interpolate, interpolation_weights
from .normalise import Normaliser, face_center, point_units, region_factors
from .projection import MOUTH_ANGLE, Projection, choose_axis, cylindrical_projection

__all__ = ["interpolation_weights", "interpolate", "antialiased_weights",
           "Normaliser", "face_center", "point_units", "region_factors",
           "Projection", "choose_axis", "cylindrical_projection", "MOUTH_ANGLE"]
