"""FAP frames and streams: what a face should do, frame by frame.

A stream is numpy arrays end to end: ``values`` [frames, 68] (column k is FAP k+1),
``mask`` [frames, 68] (which FAPs the frame transmits), and for the high-level FAPs
``visemes`` [frames, 4] (viseme_select1, viseme_select2, viseme_blend, viseme_def) and
``expressions`` [frames, 6] (expression_select1, expression_intensity1,
expression_select2, expression_intensity2, init_face, expression_def).

**FAPs a frame leaves out** (mask 0) keep the value they were last given, and are 0
(neutral) until they are first given: :meth:`FapStream.held` applies this rule, and
playback, resampling and the range checks use it.  This is the decoder behaviour of
MPEG-4 without a FIT (the FIT, which may derive untransmitted FAPs from others, is not
applied here).

Example
-------
>>> s = FapStream.from_values({"open_jaw": [0, 100, 200], 48: [0, 0, 500]}, fps=25)
>>> len(s), s.duration, s.animated
(3, 0.12, [3, 48])
>>> s[1]["open_jaw"], s[1][48]
(100.0, 0.0)
>>> s.resample(50)[3]["open_jaw"]          # 0.06 s: halfway between frames 1 and 2
150.0
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Iterator, Mapping, Optional, Sequence, Union

import numpy as np

from .tables import FAP, N_FAPS, FapRecord

__all__ = ["FapFrame", "FapStream", "FapRangeWarning", "VISEME_FIELDS", "EXPRESSION_FIELDS"]

VISEME_FIELDS = ("viseme_select1", "viseme_select2", "viseme_blend", "viseme_def")
EXPRESSION_FIELDS = ("expression_select1", "expression_intensity1", "expression_select2",
                     "expression_intensity2", "init_face", "expression_def")
MAX_FRAMES = 1_000_000    # 11 hours at 25 fps; its values alone take 0.5 GB

# Bounds of each high-level field (selects: viseme 0-14, expression 0-6; blend and
# intensities 0-63; the flags 0-1).
_VISEME_MAX = np.array([14, 14, 63, 1])
_EXPRESSION_MAX = np.array([6, 63, 6, 63, 1, 1])


class FapRangeWarning(UserWarning):
    """A FAP value outside the range the standard gives it."""


def _col(fap: Union[int, str, FapRecord]) -> int:
    return FAP.number(fap) - 1


@dataclass(frozen=True)
class FapFrame:
    """One frame: ``frame[fap]`` is the value of a transmitted FAP, or None.

    ``mask``/``values`` are 68 long (index = FAP number - 1); ``viseme`` and
    ``expression`` hold the FAP 1 and FAP 2 fields.
    """

    number: int
    mask: np.ndarray
    values: np.ndarray
    viseme: np.ndarray
    expression: np.ndarray

    def __getitem__(self, fap) -> Optional[float]:
        c = _col(fap)
        if not self.mask[c]:
            return None
        if c == 0:
            return dict(zip(VISEME_FIELDS, self.viseme.tolist()))
        if c == 1:
            return dict(zip(EXPRESSION_FIELDS, self.expression.tolist()))
        return float(self.values[c])

    @property
    def faps(self) -> list:
        """Numbers of the FAPs this frame transmits."""
        return (np.flatnonzero(self.mask) + 1).tolist()


class FapStream:
    """A FAP animation: frames at ``fps`` frames per second.

    Build one with :meth:`from_values` or :meth:`from_arrays`; read and write files
    with ``mpeg4fba.read_fap`` / ``write_fap``.  ``stream[i]`` is a :class:`FapFrame`,
    ``stream[a:b]`` a shorter stream, ``a + b`` (same fps) the two one after the other.
    """

    def __init__(self, values: np.ndarray, mask: np.ndarray, fps: float,
                 visemes: Optional[np.ndarray] = None, expressions: Optional[np.ndarray] = None,
                 name: str = "", version: str = "2.1"):
        values = np.asarray(values, dtype=np.float64)
        n = len(values)
        if values.ndim != 2 or values.shape[1] != N_FAPS:
            raise ValueError(f"FAP values must be an array [frames, {N_FAPS}], not {values.shape}")
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != values.shape:
            raise ValueError(f"the mask must have the shape of the values {values.shape}, "
                             f"not {mask.shape}")
        if not np.isfinite(values).all():
            frame, col = np.argwhere(~np.isfinite(values))[0]
            raise ValueError(f"frame {frame}: FAP {col + 1} is not a finite number")
        fps = float(fps)
        if not fps > 0 or not np.isfinite(fps):
            raise ValueError(f"fps must be a positive number, not {fps}")
        self.values = values
        self.mask = mask
        self.fps = fps
        self.visemes = _fields(visemes, n, 4, "visemes")
        self.expressions = _fields(expressions, n, 6, "expressions")
        self.name = name
        self.version = version

    # -- construction ------------------------------------------------------------------
    @classmethod
    def from_values(cls, faps: Mapping, fps: float = 25.0, n_frames: Optional[int] = None,
                    **kw) -> "FapStream":
        """A stream from ``{fap: values per frame}`` (fap by number or name).

        A scalar is held over all frames; every FAP given is transmitted in every frame.
        """
        cols = {_col(k): np.atleast_1d(np.asarray(v, dtype=np.float64)) for k, v in faps.items()}
        lengths = {len(v) for v in cols.values() if len(v) > 1}
        if len(lengths) > 1:
            raise ValueError(f"FAP value lists differ in length: {sorted(lengths)}")
        n = n_frames if n_frames is not None else (lengths.pop() if lengths else 1)
        values = np.zeros((n, N_FAPS))
        mask = np.zeros((n, N_FAPS), dtype=bool)
        for c, v in cols.items():
            if c < 2:
                raise ValueError("FAPs 1 and 2 take visemes=/expressions= arrays, not values")
            values[:, c] = v if len(v) > 1 else v[0]
            mask[:, c] = True
        out = cls(values, mask, fps, **kw)
        if kw.get("visemes") is not None:
            out.mask[:, 0] = True
        if kw.get("expressions") is not None:
            out.mask[:, 1] = True
        return out

    @classmethod
    def empty(cls, fps: float = 25.0) -> "FapStream":
        return cls(np.zeros((0, N_FAPS)), np.zeros((0, N_FAPS), bool), fps)

    # -- sequence -------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, index):
        if isinstance(index, slice):
            start, stop, step = index.indices(len(self))
            if step != 1:
                raise ValueError("slice FAP streams with step 1; use resample() to change the rate")
            return self._take(slice(start, stop))
        i = int(index)
        if i < 0:
            i += len(self)
        if not 0 <= i < len(self):
            raise IndexError(f"frame {index} of a {len(self)}-frame stream")
        return FapFrame(i, self.mask[i], self.values[i], self.visemes[i], self.expressions[i])

    def __iter__(self) -> Iterator[FapFrame]:
        return (self[i] for i in range(len(self)))

    def _take(self, rows) -> "FapStream":
        return FapStream(self.values[rows], self.mask[rows], self.fps, self.visemes[rows],
                         self.expressions[rows], self.name, self.version)

    def __add__(self, other: "FapStream") -> "FapStream":
        return FapStream.concat([self, other])

    @classmethod
    def concat(cls, streams: Sequence["FapStream"]) -> "FapStream":
        """Streams one after the other; they must share a frame rate."""
        streams = list(streams)
        if not streams:
            raise ValueError("nothing to concatenate")
        rates = {s.fps for s in streams}
        if len(rates) > 1:
            raise ValueError(f"streams at different frame rates {sorted(rates)}: resample first")
        return cls(np.concatenate([s.values for s in streams]),
                   np.concatenate([s.mask for s in streams]), streams[0].fps,
                   np.concatenate([s.visemes for s in streams]),
                   np.concatenate([s.expressions for s in streams]),
                   streams[0].name, streams[0].version)

    def __eq__(self, other) -> bool:
        if not isinstance(other, FapStream):
            return NotImplemented
        # Columns 0 and 1 (FAPs 1 and 2) carry no value: their fields are compared below.
        return (self.fps == other.fps and np.array_equal(self.mask, other.mask)
                and np.array_equal(np.where(self.mask, self.values, 0)[:, 2:],
                                   np.where(other.mask, other.values, 0)[:, 2:])
                and np.array_equal(self.visemes[self.mask[:, 0]], other.visemes[other.mask[:, 0]])
                and np.array_equal(self.expressions[self.mask[:, 1]],
                                   other.expressions[other.mask[:, 1]]))

    # -- facts --------------------------------------------------------------------------------
    @property
    def duration(self) -> float:
        """Seconds covered: frames / fps."""
        return round(len(self) / self.fps, 12)

    @property
    def times(self) -> np.ndarray:
        """The time of each frame, in seconds."""
        return np.arange(len(self)) / self.fps

    @property
    def animated(self) -> list:
        """FAP numbers transmitted in at least one frame."""
        return (np.flatnonzero(self.mask.any(axis=0)) + 1).tolist()

    def held(self) -> tuple:
        """(values, mask) with the rule for FAPs a frame leaves out applied.

        A FAP keeps its last transmitted value; before its first it is 0.  The mask says
        which FAPs have been given by each frame.  Also applies to the viseme and
        expression fields, returned as ``(values, mask, visemes, expressions)``.
        """
        n = len(self)
        if n == 0:
            return self.values.copy(), self.mask.copy(), self.visemes.copy(), self.expressions.copy()
        rows = np.where(self.mask, np.arange(n)[:, None], -1)
        last = np.maximum.accumulate(rows, axis=0)       # last frame that gave each FAP
        given = last >= 0
        values = np.where(given, self.values[np.maximum(last, 0), np.arange(N_FAPS)], 0.0)
        vis = np.where(given[:, :1], self.visemes[np.maximum(last[:, 0], 0)], 0)
        exp = np.where(given[:, 1:2], self.expressions[np.maximum(last[:, 1], 0)], 0)
        return values, given, vis, exp

    def resample(self, fps: float) -> "FapStream":
        """The stream at another frame rate, same duration.

        Low-level FAPs are interpolated linearly between the (held) values of the two
        nearest frames; the viseme and expression fields, being selections, take the
        frame at or before each new time.  A FAP is transmitted in a new frame once it
        has been given at or before it.
        """
        fps = float(fps)
        if not fps > 0:
            raise ValueError(f"fps must be positive, not {fps}")
        n = len(self)
        if n == 0:
            return FapStream.empty(fps)
        m = max(1, int(np.floor(n * fps / self.fps + 1e-9)))
        if m > MAX_FRAMES:
            # refused before the arrays: a stream read at fps=1e-5 would ask for billions
            raise ValueError(f"resampling {n} frames at {self.fps:g} fps to {fps:g} fps makes "
                             f"{m:,} frames, more than {MAX_FRAMES:,}")
        values, given, vis, exp = self.held()
        t = np.arange(m) * (self.fps / fps)              # new times, in old frame units
        lo = np.minimum(np.floor(t + 1e-9).astype(int), n - 1)
        hi = np.minimum(lo + 1, n - 1)
        w = np.clip(t - lo, 0.0, 1.0)[:, None]
        new = values[lo] * (1 - w) + values[hi] * w
        # Interpolate only between frames where the FAP was given; else hold.
        new = np.where(given[hi] & given[lo], new, values[lo])
        return FapStream(new, given[lo], fps, vis[lo], exp[lo], self.name, self.version)

    # -- checks -------------------------------------------------------------------------------
    def out_of_range(self) -> list:
        """(frame, FAP number, value) for every transmitted value outside its range.

        Low-level FAPs are checked against ``FAP[n].range``; the viseme and expression
        fields against their bounds (selects 0-14 and 0-6, blend and intensities 0-63).
        """
        lo = np.array([r.range[0] if r.range else -np.inf for r in FAP])
        hi = np.array([r.range[1] if r.range else np.inf for r in FAP])
        bad = self.mask & ((self.values < lo) | (self.values > hi))
        out = [(int(f), int(c) + 1, float(self.values[f, c])) for f, c in np.argwhere(bad)]
        for col, arr, top in ((0, self.visemes, _VISEME_MAX), (1, self.expressions, _EXPRESSION_MAX)):
            wrong = self.mask[:, col:col + 1] & ((arr < 0) | (arr > top))
            for f in np.flatnonzero(wrong.any(axis=1)):
                out.append((int(f), col + 1, arr[f].tolist()))
        return sorted(out)

    def warn_out_of_range(self, source: str = "", limit: int = 5) -> int:
        """Warn (FapRangeWarning) about out-of-range values, naming FAP and frame."""
        bad = self.out_of_range()
        where = f"{source}: " if source else ""
        for frame, fap, value in bad[:limit]:
            r = FAP[fap]
            bounds = f"{r.range[0]:g} to {r.range[1]:g}" if r.range else "its field bounds"
            warnings.warn(f"{where}frame {frame}: FAP {fap} {r.name} = {value} is outside "
                          f"{bounds}", FapRangeWarning, stacklevel=2)
        if len(bad) > limit:
            warnings.warn(f"{where}{len(bad) - limit} more values outside their range",
                          FapRangeWarning, stacklevel=2)
        return len(bad)

    def summary(self) -> dict:
        """Frames, fps, duration, and min/max per animated FAP (for ``mpeg4fba info``)."""
        faps = {}
        for f in self.animated:
            c = f - 1
            if f <= 2:
                faps[f] = {"name": FAP[f].name, "frames": int(self.mask[:, c].sum())}
                continue
            v = self.values[self.mask[:, c], c]
            faps[f] = {"name": FAP[f].name, "frames": int(len(v)), "min": float(v.min()),
                       "max": float(v.max())}
        return {"name": self.name, "version": self.version, "frames": len(self),
                "fps": self.fps, "duration": self.duration, "faps": faps}

    def __repr__(self) -> str:
        return (f"<FapStream {len(self)} frames at {self.fps:g} fps, "
                f"{len(self.animated)} FAPs animated>")


def _fields(arr, n: int, width: int, what: str) -> np.ndarray:
    if arr is None:
        return np.zeros((n, width), dtype=np.int32)
    arr = np.asarray(arr)
    if arr.ndim == 1 and arr.shape == (width,):
        arr = np.tile(arr, (n, 1))
    if arr.shape != (n, width):
        raise ValueError(f"{what} must be an array [{n}, {width}], not {arr.shape}")
    if not np.array_equal(arr, np.round(arr)):
        raise ValueError(f"{what} fields are integers")
    if arr.size and np.abs(arr).max() >= 2 ** 31:
        raise ValueError(f"{what} fields are small integers; {arr.flat[np.argmax(np.abs(arr))]} "
                         "does not fit their 32 bits")
    return arr.astype(np.int32)
