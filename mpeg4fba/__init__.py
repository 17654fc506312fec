"""mpeg4fba: MPEG-4 Face and Body Animation toolkit.

>>> import mpeg4fba as fba
>>> fba.vrml.loads("#VRML V2.0 utf8\\nGroup {}").nodes[0].type
'Group'
>>> fba.FAP[3].name
'open_jaw'
"""
from . import fba as standard
from . import vrml
from .fba import (EXPRESSIONS, FAP, FAPU, FEATURE_POINTS, VISEMES, FapFrame, FapStream,
                  FeaturePointSet)
from .formats.fap import read_fap, write_fap
from .fba.face import FaceModel
from .formats.validate import validate
from .formats.wrl_face import load_face, save_face
from .cloning import clone

__version__ = "0.1.0"
__all__ = ["vrml", "standard", "FAP", "FAPU", "FEATURE_POINTS", "VISEMES", "EXPRESSIONS",
           "FapFrame", "FapStream", "FeaturePointSet", "read_fap", "write_fap", "load_face",
           "save_face", "FaceModel", "validate", "clone", "__version__"]
