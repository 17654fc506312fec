"""Phonemes with times -> a FAP stream: visemes that blend into each other, a jaw that
follows the vowels, lips that shut on p, b and m, and a neutral mouth in pauses.

The phonemes become mouth *segments* (each phoneme one; a diphthong two, its glide
starting halfway); a segment of the ``carry`` kind (h, the glottal stop) takes the
shape of the segment after it.  Segment j starts at ``a[j]`` and is entered through a
window in which FAP 1 blends the previous viseme into its own (``viseme_select1`` the
new one, ``viseme_select2`` the old, ``viseme_blend`` 0-63 the new one's share):

* ordinary segments: the window is centred on the start, ``[a - h, a + h]``, so the
  new viseme is the larger share from its phoneme's first sample on;
* closures (p, b, m): the window ends at the start, ``[a - h, a]``, so the lips are
  fully shut when the sound of the closure begins; a closure too short for any frame to
  fall in its shut part gets the frame at or just before its start shut.

``h`` is half of :data:`TRANSITION` (60 ms: coarticulation of adjacent visemes in
running speech takes some 50-80 ms), and never more than half of either neighbouring
segment, so windows never overlap and a frame mixes at most two visemes, as FAP 1
allows.  The jaw (FAP 3, ``open_jaw``) follows the same windows, linearly, from each
segment's opening (the phoneme table's ``jaw``, 0-1) times ``jaw`` FAP units: the
visemes carry the mouth's shape, the jaw adds how open each vowel is.  Pauses are
viseme 0 and a closed jaw.

>>> from mpeg4fba.speech.engine import PhonemeEvent
>>> ph = [PhonemeEvent("_", 0, 0, 0), PhonemeEvent("p", 2205, 1, 1), PhonemeEvent("'A:", 4410, 1, 2),
...       PhonemeEvent("_", 8820, 1, 4)]
>>> s = phoneme_stream(ph, 22050, 11025, fps=25)
>>> len(s), s.visemes[3].tolist()            # 0.12 s: the lips shut for p
(13, [1, 0, 63, 0])
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..fba.stream import FapStream
from ..fba.tables import FAP, N_FAPS
from .phonemes import phoneme_shape

__all__ = ["phoneme_stream", "segments", "TRANSITION", "JAW"]

#: Seconds one viseme takes to blend into the next.
TRANSITION = 0.06
#: open_jaw (MNS/1024 units) at the widest vowel, on top of the visemes' own opening.
JAW = 150.0


def segments(phonemes: Sequence, sample_rate: int, n_samples: int) -> tuple:
    """(start seconds, viseme, jaw 0-1, is closure) arrays of the mouth segments, a
    neutral one first at 0 s."""
    starts, vis, jaw, closure = [0.0], [0], [0.0], [False]
    end = n_samples / sample_rate
    shapes = [phoneme_shape(p.name) for p in phonemes]
    times = [min(p.sample / sample_rate, end) for p in phonemes]
    for k, (shape, t) in enumerate(zip(shapes, times)):
        nxt_t = times[k + 1] if k + 1 < len(times) else end
        if shape.kind == "carry":
            # the next phoneme's shape, a little less open (none of its own)
            after = next((s for s in shapes[k + 1:] if s.kind != "carry"), None)
            if after is None or after.kind == "pause":
                shape_v, shape_j = 0, 0.0
            else:
                shape_v, shape_j = after.viseme, after.jaw * 0.7
            starts.append(t), vis.append(shape_v), jaw.append(shape_j), closure.append(False)
            continue
        starts.append(t), vis.append(shape.viseme), jaw.append(shape.jaw)
        closure.append(shape.kind == "closure")
        if shape.viseme2 is not None and nxt_t > t:
            starts.append(t + 0.5 * (nxt_t - t)), vis.append(shape.viseme2)
            jaw.append(shape.jaw2), closure.append(False)
    a = np.array(starts)
    # same start (a zero-length phoneme): the later one wins
    keep = np.append(a[1:] > a[:-1], True)
    return a[keep], np.array(vis)[keep], np.array(jaw)[keep], np.array(closure)[keep]


def phoneme_stream(phonemes: Sequence, sample_rate: int, n_samples: int, *, fps: float = 25.0,
                   transition: float = TRANSITION, jaw: float = JAW,
                   expression: Optional[int] = None, intensity: int = 40,
                   name: str = "speech") -> FapStream:
    """The FAP stream of ``phonemes`` (:class:`~mpeg4fba.speech.engine.PhonemeEvent` s
    at samples of ``sample_rate``) over ``n_samples`` of audio: ``round(seconds x fps)``
    frames, FAP 1 and FAP 3 in each, and FAP 2 holding ``expression`` (0-6, or None for
    none) at ``intensity`` (0-63) when given."""
    if not fps > 0:
        raise ValueError(f"fps must be > 0, not {fps}")
    if not 0 <= transition <= 1:
        raise ValueError(f"transition {transition}: 0 to 1 second")
    a, vis, opening, closure = segments(phonemes, sample_rate, n_samples)
    end = n_samples / sample_rate
    n = max(1, int(np.floor(end * fps + 0.5)))
    t = np.arange(n) / fps
    dur = np.diff(np.append(a, max(end, a[-1]) + 1e-9))
    prev = np.concatenate([[0.0], dur[:-1]])
    h = np.minimum.reduce([np.full(len(a), transition / 2), 0.5 * dur, 0.5 * prev])
    h[0] = 0.0
    lo = a - h
    hi = np.where(closure, a, a + h)
    # the last window begun at each frame: in it, blending from the segment before
    i = np.clip(np.searchsorted(lo, t, side="right") - 1, 0, len(a) - 1)
    span = hi[i] - lo[i]
    w = np.where(span > 0, np.clip((t - lo[i]) / np.where(span > 0, span, 1), 0, 1), 1.0)
    before = np.maximum(i - 1, 0)
    # a closure too short for a frame to fall where the lips are shut: the frame at or
    # just before its start shuts them (lips close ahead of the burst; the frame after
    # is the next phoneme's onset, kept for it)
    shut = np.flatnonzero(closure)
    stop = np.append(lo[1:], end)[shut]
    first = np.searchsorted(t, a[shut])          # the first frame at or after the start
    missed = (first >= n) | (t[np.minimum(first, n - 1)] >= stop)
    for j in shut[missed]:
        f = int(np.clip(np.floor(a[j] * fps + 1e-9), 0, n - 1))
        i[f], w[f], before[f] = j, 1.0, max(j - 1, 0)
    blend = np.round(63 * w).astype(int)
    visemes = np.column_stack([vis[i], vis[before], blend, np.zeros(n, int)])
    values = np.zeros((n, N_FAPS))
    mask = np.zeros((n, N_FAPS), dtype=bool)
    col = FAP["open_jaw"].number - 1
    values[:, col] = np.round(jaw * (w * opening[i] + (1 - w) * opening[before]))
    mask[:, col] = True
    mask[:, 0] = True
    expressions = None
    if expression is not None:
        if not 0 <= int(expression) <= 6 or not 0 <= int(intensity) <= 63:
            raise ValueError(f"expression {expression} at {intensity}: 0-6 at 0-63")
        expressions = np.tile([int(expression), int(intensity), 0, 0, 0, 0], (n, 1))
        mask[:, 1] = True
    return FapStream(values, mask, fps, visemes=visemes, expressions=expressions, name=name)
