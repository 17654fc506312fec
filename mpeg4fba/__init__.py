"""mpeg4fba: MPEG-4 Face and Body Animation toolkit.

>>> import mpeg4fba as fba
>>> fba.vrml.loads("#VRML V2.0 utf8\\nGroup {}").nodes[0].type
'Group'
>>> fba.FAP[3].name
'open_jaw'

The names below are imported on first use (PEP 562), so ``import mpeg4fba.vrml`` or the
command line's ``--help`` does not pay for scipy and the cloner.
"""
from __future__ import annotations

from ._lazy import lazy_names

__version__ = "0.1.0"

#: public name -> (module, attribute; None for the module itself)
_LAZY = {
    "vrml": ("mpeg4fba.vrml", None),
    "standard": ("mpeg4fba.fba", None),
    **{name: ("mpeg4fba.fba", name) for name in (
        "EXPRESSIONS", "FAP", "FAPU", "FEATURE_POINTS", "VISEMES", "FapFrame", "FapStream",
        "FeaturePointSet")},
    "read_fap": ("mpeg4fba.formats.fap", "read_fap"),
    "write_fap": ("mpeg4fba.formats.fap", "write_fap"),
    "FaceModel": ("mpeg4fba.fba.face", "FaceModel"),
    "validate": ("mpeg4fba.formats.validate", "validate"),
    "load_face": ("mpeg4fba.formats.wrl_face", "load_face"),
    "save_face": ("mpeg4fba.formats.wrl_face", "save_face"),
    "clone": ("mpeg4fba.cloning", "clone"),
}

__all__ = ["vrml", "standard", "FAP", "FAPU", "FEATURE_POINTS", "VISEMES", "EXPRESSIONS",
           "FapFrame", "FapStream", "FeaturePointSet", "read_fap", "write_fap", "load_face",
           "save_face", "FaceModel", "validate", "clone", "__version__"]


__getattr__, __dir__ = lazy_names(globals(), _LAZY)
