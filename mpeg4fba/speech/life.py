"""A talking face that also blinks and moves its head a little (``say(..., life=True)``).

Blinks: the upper lids close for about 150 ms (FAPs 19 and 20 at 1,000 IRISD units at
the peak), the first at 0.4-0.9 s, then every 2.5-5 s, people's resting rate while
speaking; head motion: slow nods and turns of a degree or two (FAPs 48 and 49, units
of 1e-5 rad), starting and ending at rest.  Both are drawn from ``seed``.

>>> import numpy as np
>>> from mpeg4fba.fba.stream import FapStream
>>> still = FapStream(np.zeros((100, 68)), np.zeros((100, 68), bool), 25.0)
>>> alive = with_blinks_and_head(still, seed=1)
>>> bool(alive.values[:, 18].max() > 900), alive.animated[:4]
(True, [19, 20, 48, 49])
"""
from __future__ import annotations

import numpy as np

from ..fba.stream import FapStream
from ..fba.tables import FAP

__all__ = ["with_blinks_and_head"]

_BLINK = 0.045          # seconds: the Gaussian's sigma (about 150 ms closed and open)


def with_blinks_and_head(stream: FapStream, seed: int = 0) -> FapStream:
    """``stream`` with blinks and a little head motion added (its other FAPs kept)."""
    n = len(stream)
    t = np.arange(n) / stream.fps
    total = n / stream.fps
    rng = np.random.default_rng(seed)
    centres = []
    c = rng.uniform(0.4, 0.9)
    while c < total - 0.1:
        centres.append(c)
        c += rng.uniform(2.5, 5.0)
    blink = np.zeros(n)
    for c in centres:
        blink += np.exp(-0.5 * ((t - c) / _BLINK) ** 2)
    fade = np.sin(np.pi * np.clip(t / max(total, 1e-9), 0, 1))       # at rest at both ends
    pitch = 2500 * fade * np.sin(2 * np.pi * t / rng.uniform(1.4, 2.0) + rng.uniform(0, 6.3))
    yaw = 4000 * fade * np.sin(2 * np.pi * t / rng.uniform(2.4, 3.4) + rng.uniform(0, 6.3))
    values, mask = stream.values.copy(), stream.mask.copy()
    for name, curve in (("close_t_l_eyelid", 1000 * np.minimum(blink, 1)),
                        ("close_t_r_eyelid", 1000 * np.minimum(blink, 1)),
                        ("head_pitch", pitch), ("head_yaw", yaw)):
        col = FAP[name].number - 1
        values[:, col] = np.round(curve)
        mask[:, col] = True
    return FapStream(values, mask, stream.fps, visemes=stream.visemes,
                     expressions=stream.expressions, name=stream.name)
