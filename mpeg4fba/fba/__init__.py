"""The MPEG-4 FBA standard as typed objects.  Knows nothing of files.

>>> from mpeg4fba import fba
>>> fba.FAP[3].name, fba.FAP["open_jaw"].fapu, len(fba.FEATURE_POINTS)
('open_jaw', 'MNS', 84)
"""
from .fapu import FAPU, FAPU_POINTS, FAPUWarning
from .featurepoints import FeaturePointError, FeaturePointSet, normalise_id, point_order
from .stream import EXPRESSION_FIELDS, VISEME_FIELDS, FapFrame, FapRangeWarning, FapStream
from .tables import (EXPRESSIONS, FAP, FAPU_NAMES, FEATURE_POINTS, LOW_LEVEL, N_FAPS, VISEMES,
                     Expression, FapRecord, FeaturePoint, Viseme)

__all__ = ["FAP", "FEATURE_POINTS", "VISEMES", "EXPRESSIONS", "N_FAPS", "LOW_LEVEL", "FAPU_NAMES",
           "FapRecord", "FeaturePoint", "Viseme", "Expression", "FAPU", "FAPU_POINTS",
           "FAPUWarning", "FeaturePointSet", "FeaturePointError", "normalise_id", "point_order",
           "FapFrame", "FapStream", "FapRangeWarning", "VISEME_FIELDS", "EXPRESSION_FIELDS"]
