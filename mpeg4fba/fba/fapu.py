"""Face Animation Parameter Units: the face's own measures that FAP values count in.

Example
-------
>>> u = FAPU(IRISD0=10.0, ES0=64.0, ENS0=40.0, MNS0=20.0, MW0=50.0)
>>> u.MNS                       # MNS0 / 1024, the unit of open_jaw
0.01953125
>>> u.unit(3) * 1024            # open_jaw at 1024 moves its point by one MNS0
20.0
>>> u.unit("head_yaw")          # angles count in 1e-5 radian
1e-05
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping, Union

import numpy as np

from .tables import FAP, FapRecord

__all__ = ["FAPU", "FAPUWarning", "FAPU_POINTS"]

AU = 1e-5  # radian

#: The feature points each FAPU0 distance is measured between (ISO/IEC 14496-2 Annex C).
FAPU_POINTS = {
    "IRISD0": ("3.1", "3.3"),   # upper and lower left eyelid, y (right eye: 3.2, 3.4)
    "ES0": ("3.5", "3.6"),      # pupil centres, x
    "ENS0": ("3.5", "9.15"),    # left pupil and the bottom middle of the nose, y
    "MNS0": ("9.15", "2.2"),    # bottom of the nose and the middle of the inner upper lip, y
    "MW0": ("8.3", "8.4"),      # outer lip corners, x
}

# Plausible proportions to ES0 (human faces and cartoon heads alike sit well inside).
_PLAUSIBLE = {"IRISD0": (0.03, 0.6), "ENS0": (0.2, 2.0), "MNS0": (0.05, 1.2), "MW0": (0.3, 2.0)}


class FAPUWarning(UserWarning):
    """A FAPU that can be computed but looks wrong (negative, zero or implausible)."""


@dataclass(frozen=True)
class FAPU:
    """The five FAPU0 distances of a neutral face, in model units.

    The units FAP values count in are these divided by 1024 (``IRISD``, ``ES``, ``ENS``,
    ``MNS``, ``MW``) and the angle unit ``AU`` = 1e-5 radian.
    """

    IRISD0: float
    ES0: float
    ENS0: float
    MNS0: float
    MW0: float

    AU = AU

    @property
    def IRISD(self) -> float:
        return self.IRISD0 / 1024.0

    @property
    def ES(self) -> float:
        return self.ES0 / 1024.0

    @property
    def ENS(self) -> float:
        return self.ENS0 / 1024.0

    @property
    def MNS(self) -> float:
        return self.MNS0 / 1024.0

    @property
    def MW(self) -> float:
        return self.MW0 / 1024.0

    def __getitem__(self, name: str) -> float:
        """A unit by name: ``u["MNS"]`` (model units per FAP unit), ``u["AU"]``."""
        if name not in ("IRISD", "ES", "ENS", "MNS", "MW", "AU"):
            raise KeyError(f"no FAPU {name!r}; the units are IRISD, ES, ENS, MNS, MW and AU")
        return getattr(self, name)

    def unit(self, fap: Union[int, str, FapRecord]) -> float:
        """Model units (or radians) per unit of FAP ``fap``; 0 for FAPs 1 and 2."""
        record = fap if isinstance(fap, FapRecord) else FAP[fap]
        return self[record.fapu] if record.fapu else 0.0

    def units(self) -> np.ndarray:
        """The unit of every FAP as an array indexed by FAP number - 1 (68 long)."""
        return np.array([self.unit(r) for r in FAP])

    def as_dict(self) -> dict:
        return {"IRISD0": self.IRISD0, "ES0": self.ES0, "ENS0": self.ENS0,
                "MNS0": self.MNS0, "MW0": self.MW0}

    @classmethod
    def from_feature_points(cls, points: Mapping) -> "FAPU":
        """The FAPU of a neutral face from its feature points (id -> x, y, z).

        IRISD0 = 3.1.y - 3.3.y (the left eye; the right eye's 3.2/3.4 when the left
        eye's points are missing, and the mean of both when both are there), ES0 =
        3.5.x - 3.6.x, ENS0 = 3.5.y - 9.15.y, MNS0 = 9.15.y - 2.2.y, MW0 = 8.3.x - 8.4.x,
        in the face frame (x = the face's left, y = up).  Raises ValueError naming the
        missing points; warns (:class:`FAPUWarning`) when a value is not positive or is
        out of proportion with the eye separation.

        >>> pts = {"3.1": (3, 5, 0), "3.3": (3, 4, 0), "3.5": (3, 4.5, 0), "3.6": (-3, 4.5, 0),
        ...        "9.15": (0, 1, 1), "2.2": (0, -0.5, 1), "8.3": (2.5, -0.5, 0.8),
        ...        "8.4": (-2.5, -0.5, 0.8)}
        >>> FAPU.from_feature_points(pts)
        FAPU(IRISD0=1.0, ES0=6.0, ENS0=3.5, MNS0=1.5, MW0=5.0)
        """
        def has(p):
            return p in points and points[p] is not None

        left_eye = has("3.1") and has("3.3")
        right_eye = has("3.2") and has("3.4")
        needed = ["3.5", "3.6", "9.15", "2.2", "8.3", "8.4"]
        missing = [p for p in needed if not has(p)]
        if not (left_eye or right_eye):
            missing = [p for p in ("3.1", "3.3") if not has(p)] + missing
        if missing:
            raise ValueError("can't compute the FAPU: feature point"
                             f"{'s' if len(missing) > 1 else ''} {', '.join(missing)} missing")
        P = {k: np.asarray(points[k], dtype=float) for k in needed + ["3.1", "3.2", "3.3", "3.4"]
             if has(k)}
        iris = []
        if left_eye:
            iris.append(P["3.1"][1] - P["3.3"][1])
        if right_eye:
            iris.append(P["3.2"][1] - P["3.4"][1])
        fapu = cls(IRISD0=float(np.mean(iris)),
                   ES0=float(P["3.5"][0] - P["3.6"][0]),
                   ENS0=float(P["3.5"][1] - P["9.15"][1]),
                   MNS0=float(P["9.15"][1] - P["2.2"][1]),
                   MW0=float(P["8.3"][0] - P["8.4"][0]))
        for problem in fapu.problems():
            warnings.warn(problem, FAPUWarning, stacklevel=2)
        return fapu

    def problems(self) -> list:
        """What looks wrong with these values (empty when nothing does)."""
        out = []
        hints = {"ES0": "the face's left (3.5) should have the larger x: left and right "
                        "are swapped, or the face looks along -z",
                 "MW0": "the face's left lip corner (8.3) should have the larger x: left and "
                        "right are swapped",
                 "IRISD0": "the upper eyelid (3.1) should be above the lower one (3.3): is y "
                           "up, or are the eyes closed? (MPEG-4's neutral face has them open)",
                 "ENS0": "the pupil (3.5) should be above the nose (9.15): is y up?",
                 "MNS0": "the nose (9.15) should be above the upper lip (2.2): is y up?"}
        for name, value in self.as_dict().items():
            if not value > 0:
                out.append(f"FAPU {name} = {value:g} is not positive; {hints[name]}")
        if self.ES0 > 0:
            for name, (lo, hi) in _PLAUSIBLE.items():
                value = getattr(self, name)
                ratio = value / self.ES0
                if value > 0 and not lo <= ratio <= hi:
                    shut = name == "IRISD0" and ratio < lo
                    out.append(f"FAPU {name} = {value:g} is {ratio:.2f} times ES0 = {self.ES0:g}; "
                               f"faces have {lo}-{hi}: check the feature points it is measured "
                               f"between ({' and '.join(FAPU_POINTS[name])})"
                               + ("; are the eyes closed? (MPEG-4's neutral face has them open)"
                                  if shut else ""))
        return out
