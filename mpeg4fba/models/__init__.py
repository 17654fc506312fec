"""Procedural face models: the reference head, a complete MPEG-4 face made in code.

>>> from mpeg4fba.models import reference_head, VISEME_FAPS, EXPRESSION_FAPS
"""
from .reference_head import MESHES, TRANSFORMS, reference_head
from .shapes import EXPRESSION_FAPS, VISEME_FAPS, high_level_tables

__all__ = ["reference_head", "MESHES", "TRANSFORMS", "VISEME_FAPS", "EXPRESSION_FAPS",
           "high_level_tables"]
