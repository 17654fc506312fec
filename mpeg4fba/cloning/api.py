"""The one entry point of motion cloning: :func:`clone` picks the method.

>>> METHODS
('fmc', 'local-frames')
"""
from __future__ import annotations

from ..fba.face import FaceModel
from .fmc import FacialMotionCloner
from .local_frames import LocalFrameCloner

__all__ = ["clone", "METHODS"]

#: The cloning methods :func:`clone` knows.
METHODS = ("fmc", "local-frames")


def clone(source: FaceModel, target: FaceModel, method: str = "fmc", **options) -> FaceModel:
    """The target face with a FAT for every FAP, viseme and expression of the source's.

    ``method="fmc"`` (default): Facial Motion Cloning, any two faces with the required
    feature points (``options`` go to :class:`FacialMotionCloner`); FeaturePointError
    listing the ids when either face lacks some, :class:`CloneWarning` for anything left
    out or installed.  ``method="local-frames"``: Kong et al.'s local-frame cloning for
    faces that share a mesh (:class:`~mpeg4fba.cloning.local_frames.LocalFrameCloner`).
    """
    if method == "fmc":
        return FacialMotionCloner(source, target, **options).clone()
    if method == "local-frames":
        return LocalFrameCloner(source, target, **options).clone()
    raise ValueError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
