"""One target's cloning as ``mpeg4fba clone`` runs it, in named steps: the target's
missing feature points found (and put in the source's convention when all were found),
the mapping, the tables, the check.  ``mpeg4fba clone`` runs the steps under its
progress bar, :mod:`mpeg4fba.batch` runs them on a worker; both therefore make the same
face from the same inputs.  Files are the caller's: the job takes and gives FaceModels.

>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.fba.fat import FAT
>>> target = reference_head(resolution=0.5, face_width=1.1, seed=2)
>>> target.fat = FAT()
>>> job = CloneJob(reference_head(resolution=0.5), target, check=False).run()
>>> len(job.result.fat.faps), job.points.added
(66, ())
"""
from __future__ import annotations

import time
from typing import Optional, Union

from ..fba.face import FaceModel
from .autopoints import PointReport, complete_points, matched_points
from .errors import check_choice
from .api import METHODS
from .fmc import FacialMotionCloner, PreparedSource
from .local_frames import LocalFrameCloner

__all__ = ["CloneJob"]


class CloneJob:
    """The cloning of one target as ``mpeg4fba clone`` runs it, step by step.

    Parameters
    ----------
    source : FaceModel or PreparedSource
        The face whose FAT is cloned (a :class:`~mpeg4fba.cloning.fmc.PreparedSource`
        when many targets share it).  Both faces may be given later, as attributes,
        before the steps run (``mpeg4fba clone`` reads them in a step of its own).
    target : FaceModel
        The face that gets the FAT; changed in place: it gets the points found on it.
    method : str
        One of :data:`~mpeg4fba.cloning.api.METHODS`.
    snap : bool
        Move the target's given crisp points onto its geometry.
    check : bool
        Validate the result (numeric FAP check included).
    scale : bool
        Scale the motion by the faces' FAPU.
    **options
        For :class:`~mpeg4fba.cloning.fmc.FacialMotionCloner` (none with local frames).

    Attributes
    ----------
    points : PointReport
        What :func:`~mpeg4fba.cloning.autopoints.complete_points` did to the target.
    cloner : FacialMotionCloner or LocalFrameCloner
    result : FaceModel
        The target with its FAT.
    report : Report or None
        The validator's (None without ``check``).
    times : dict
        Step label -> seconds (:meth:`run`).
    """

    def __init__(self, source: Union[FaceModel, PreparedSource, None],
                 target: Optional[FaceModel], *,
                 method: str = "fmc", snap: bool = False, check: bool = True,
                 scale: bool = True, **options):
        check_choice("method", method, METHODS)
        if method == "local-frames" and options:
            raise ValueError(f"the local-frame method takes no {', '.join(sorted(options))}")
        self.source, self.target = source, target
        self.method, self.snap, self.check, self.scale = method, bool(snap), bool(check), bool(scale)
        self.options = options
        self.points: Optional[PointReport] = None
        self.cloner = None
        self.result: Optional[FaceModel] = None
        self.report = None
        self.times: dict = {}

    @property
    def source_face(self) -> FaceModel:
        """The source as a FaceModel (a prepared one's face)."""
        return self.source.face if isinstance(self.source, PreparedSource) else self.source

    def steps(self) -> list:
        """(label, function) of each step, in order."""
        out = [("finding feature points", self.find_points), ("mapping the faces", self.map),
               ("cloning the tables", self.tables)]
        return out + [("checking the result", self.validate)] * self.check

    def run(self) -> "CloneJob":
        """Every step, timed into ``times``."""
        for label, step in self.steps():
            t = time.perf_counter()
            step()
            self.times[label] = time.perf_counter() - t
        return self

    def find_points(self) -> None:
        """The points the target lacks, found on its geometry; all of them found: moved
        into the source's convention (the mapping needs both faces' points to agree more
        than it needs them to be anyone's "right")."""
        target = self.target
        found = self.source.found if isinstance(self.source, PreparedSource) else None
        self.points = complete_points(target, snap=self.snap, source=self.source_face,
                                      source_found=found)
        if self.points.added and not self.points.kept:
            target.points = matched_points(target, self.points.found, self.source_face,
                                           source_found=found)

    def found_points(self) -> Optional[tuple]:
        """(the target's points as positions, confidence of each found one) to write
        beside the output for review, or None when every point was given."""
        if not self.points or not self.points.added:
            return None
        conf = self.points.found.confidence
        return (self.target.points.positions_only(),
                {k: conf[k] for k in self.points.added if k in conf})

    def map(self) -> None:
        if self.method == "local-frames":
            self.cloner = LocalFrameCloner(self.source_face, self.target, scale=self.scale)
        else:
            self.cloner = FacialMotionCloner(self.source, self.target, scale_motion=self.scale,
                                             **self.options)

    def tables(self) -> None:
        self.result = self.cloner.clone()

    def validate(self) -> None:
        from ..formats.validate import validate
        self.report = validate(self.result)

