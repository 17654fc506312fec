"""The demo's FAP stream: a spoken phrase as visemes, an expression arc, blinks and a
little head motion, written by us and shipped as ``data/demo_phrase.fap``.

:func:`demo_stream` reads the packaged file; :func:`make_demo_stream` builds it from the
phrase below (``python -m mpeg4fba.models.phrase`` rewrites the file; a test checks the
two agree).  The phrase is "Hello! I am a cloned face.", as phonemes with durations, each
phoneme mapped to the standard's viseme; consecutive visemes cross-fade through
``viseme_blend`` (FAP 1 carries two visemes and the share of the first).

>>> s = demo_stream()
>>> s.fps, len(s) > 60, bool(s.visemes[:, 0].max() <= 14)
(25.0, True, True)
"""
from __future__ import annotations

from importlib import resources
from typing import Optional

import numpy as np

from ..fba.stream import FapStream
from ..fba.tables import FAP, N_FAPS, VISEMES

__all__ = ["PHRASE", "demo_stream", "make_demo_stream", "PHRASE_TEXT", "with_life"]

PHRASE_TEXT = "Hello! I am a cloned face."
FPS = 25.0

#: (phoneme, viseme name, milliseconds).  "" is silence (viseme 0).
PHRASE = (
    ("", "none", 280),
    ("h", "aa", 60), ("e", "E", 110), ("l", "nn", 80), ("ou", "oh", 160),
    ("", "none", 200),
    ("ai", "aa", 140), ("i", "ih", 70), ("m", "PP", 110),
    ("@", "E", 70),
    ("k", "kk", 80), ("l", "nn", 70), ("ou", "oh", 150), ("n", "nn", 70), ("d", "DD", 60),
    ("f", "FF", 110), ("ei", "E", 120), ("i", "ih", 60), ("s", "SS", 150),
    ("", "none", 400),
)
_VISEME = {v.name: v.number for v in VISEMES}


def make_demo_stream() -> FapStream:
    """Build the demo stream from :data:`PHRASE` (deterministic)."""
    starts = np.cumsum([0] + [ms for _, _, ms in PHRASE])
    total = starts[-1] / 1000.0
    n = int(round(total * FPS)) + 1
    t = np.arange(n) / FPS * 1000.0
    # the phoneme each frame is in, and how far through it
    k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(PHRASE) - 1)
    frac = (t - starts[k]) / np.array([ms for _, _, ms in PHRASE])[k]
    cur = np.array([_VISEME[PHRASE[i][1]] for i in k])
    nxt = np.array([_VISEME[PHRASE[min(i + 1, len(PHRASE) - 1)][1]] for i in k])
    # hold the viseme for the first 60 % of the phoneme, then cross-fade into the next
    share = np.clip((1.0 - frac) / 0.4, 0.0, 1.0)
    blend = np.round(63 * share).astype(int)
    visemes = np.column_stack([cur, nxt, blend, np.zeros(n, int)])
    mask = np.zeros((n, N_FAPS), dtype=bool)
    values = np.zeros((n, N_FAPS))
    mask[:, 0] = True
    base = FapStream(values, mask, FPS, visemes=visemes, name="demo_phrase")
    return with_life(base, total)


def with_life(stream: FapStream, total: Optional[float] = None) -> FapStream:
    """``stream`` (its visemes and jaw kept) with the demo's life added over its length:
    an arc of joy (FAP 2), two blinks, a little nodding and turning of the head, the
    brows lifting on "Hello!".  The demo adds it to the phrase as spoken by
    :mod:`mpeg4fba.speech` too.  ``total``: the seconds the arcs span (default the
    stream's duration)."""
    n = len(stream)
    t = np.arange(n) / stream.fps * 1000.0
    total = max(n / stream.fps if total is None else float(total), 1e-9)
    values = stream.values.copy()
    mask = stream.mask.copy()
    # an arc of joy: up through the phrase, down at the end
    u = t / 1000.0 / total
    joy = np.round(48 * np.sin(np.pi * np.clip(u * 1.1, 0, 1)) ** 2).astype(int)
    expressions = np.column_stack([np.full(n, 1), joy, np.zeros(n, int), np.zeros(n, int),
                                   np.zeros(n, int), np.zeros(n, int)])

    def put(fap: str, curve: np.ndarray) -> None:
        c = FAP[fap].number - 1
        values[:, c] = np.round(curve)
        mask[:, c] = True

    # two blinks: the upper lids close for ~150 ms
    blink = np.zeros(n)
    for centre in (0.55, 2.2):
        blink += np.exp(-0.5 * ((t / 1000.0 - centre) / 0.045) ** 2)
    put("close_t_l_eyelid", 1000 * blink)
    put("close_t_r_eyelid", 1000 * blink)
    # the head nods and turns a little (units of 1e-5 rad)
    put("head_pitch", 3000 * np.sin(2 * np.pi * t / 1000.0 / 1.6) * np.sin(np.pi * u))
    put("head_yaw", 5000 * np.sin(2 * np.pi * t / 1000.0 / 2.7))
    # the brows lift on "Hello!"
    lift = 250 * np.exp(-0.5 * ((t / 1000.0 - 0.55) / 0.18) ** 2)
    for f in ("raise_l_i_eyebrow", "raise_r_i_eyebrow", "raise_l_m_eyebrow", "raise_r_m_eyebrow"):
        put(f, lift)
    mask[:, 1] = True
    return FapStream(values, mask, stream.fps, visemes=stream.visemes, expressions=expressions,
                     name=stream.name or "demo_phrase")


def demo_stream() -> FapStream:
    """The packaged demo stream (``mpeg4fba/models/data/demo_phrase.fap``)."""
    from ..formats.fap import loads_fap
    text = resources.files(__package__).joinpath("data/demo_phrase.fap").read_text(encoding="utf-8")
    return loads_fap(text, "demo_phrase.fap")


if __name__ == "__main__":  # pragma: no cover - regenerates the package data
    from pathlib import Path

    from ..formats.fap import write_fap
    out = Path(__file__).with_name("data") / "demo_phrase.fap"
    out.parent.mkdir(exist_ok=True)
    write_fap(make_demo_stream(), out)
    print(f"wrote {out}")
