"""WAV audio: 16-bit PCM mono, the speech's sound beside an animation.

>>> import numpy as np
>>> data = dumps_wav(np.array([0, 1000, -1000], np.int16), 22050)
>>> samples, rate = loads_wav(data)
>>> samples.tolist(), rate
([0, 1000, -1000], 22050)
"""
from __future__ import annotations

import io
import os
import struct
import wave
from typing import Optional, Union

import numpy as np

from .._atomic import atomic_write
from .errors import FormatError

__all__ = ["dumps_wav", "loads_wav", "write_wav", "read_wav", "MAX_SAMPLES"]

PathLike = Union[str, "os.PathLike[str]"]
#: The most samples read from one file (about 6 hours at 22,050 Hz; 1 GB of int16).
MAX_SAMPLES = 1 << 29


def dumps_wav(samples: np.ndarray, sample_rate: int) -> bytes:
    """The bytes of a mono 16-bit PCM WAV file holding ``samples``."""
    samples = np.asarray(samples)
    if samples.ndim != 1:
        raise ValueError(f"mono samples: a 1-D array, not shape {samples.shape}")
    if not 1 <= int(sample_rate) <= 384_000:
        raise ValueError(f"sample rate {sample_rate}: 1 to 384000 Hz")
    if samples.dtype.kind == "f":
        samples = np.round(np.clip(samples, -1, 1) * 32767)
    out = io.BytesIO()
    with wave.open(out, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(int(sample_rate))
        w.writeframes(samples.astype("<i2").tobytes())
    return out.getvalue()


def write_wav(samples: np.ndarray, sample_rate: int, path: PathLike) -> None:
    """Write ``samples`` to ``path`` (atomically)."""
    atomic_write(path, dumps_wav(samples, sample_rate))


def loads_wav(data: bytes, path: Optional[str] = None) -> tuple:
    """(int16 samples, sample rate) of a 16-bit PCM WAV file (several channels are
    averaged to one).  The RIFF chunks are read here, each bounded by the data: a
    damaged header is a :class:`FormatError` naming the byte where it goes wrong."""
    data = bytes(data)
    if len(data) < 12 or data[:4] != b"RIFF" or data[8:12] != b"WAVE":
        raise FormatError("not a WAV file: expected 'RIFF' and 'WAVE' in the first 12 bytes", path)
    fmt = None
    pos = 12
    while pos + 8 <= len(data):
        cid, size = data[pos:pos + 4], struct.unpack_from("<I", data, pos + 4)[0]
        body = data[pos + 8:pos + 8 + size]
        if cid == b"fmt ":
            if len(body) < 16:
                raise FormatError(f"byte {pos}: a 'fmt ' chunk of {len(body)} bytes; expected 16 or more",
                                  path)
            tag, channels, rate, _, _, bits = struct.unpack_from("<HHIIHH", body)
            if tag not in (1, 0xFFFE) or bits != 16:
                raise FormatError(f"byte {pos}: format {tag}, {bits}-bit samples; expected "
                                  "16-bit PCM", path)
            if not channels or not rate:
                raise FormatError(f"byte {pos}: {channels} channels at {rate} Hz", path)
            fmt = (channels, rate)
        elif cid == b"data":
            if fmt is None:
                raise FormatError(f"byte {pos}: the 'data' chunk comes before 'fmt '", path)
            channels, rate = fmt
            n = len(body) // (2 * channels)
            if n * channels > MAX_SAMPLES:
                raise FormatError(f"{n * channels} samples: more than the {MAX_SAMPLES} read", path)
            samples = np.frombuffer(body[: n * 2 * channels], dtype="<i2")
            if channels > 1:
                samples = samples.reshape(n, channels).mean(axis=1).round()
            return samples.astype(np.int16), rate
        pos += 8 + size + (size & 1)
    raise FormatError("no 'data' chunk" if fmt else "no 'fmt ' chunk", path)


def read_wav(path: PathLike) -> tuple:
    """(int16 samples, sample rate) of the WAV file at ``path``."""
    p = os.fspath(path)
    size = os.path.getsize(p)
    if size > 2 * MAX_SAMPLES + 1024:
        raise FormatError(f"a WAV file of {size} bytes is more than is read", p)
    with open(p, "rb") as f:
        return loads_wav(f.read(), p)
