"""Talking heads from text: eSpeak NG speaks, its phonemes become visemes in time.

:func:`say` synthesises ``text`` (:mod:`~mpeg4fba.speech.engine`: audio and phoneme
events from the same synthesis, so sound and mouth can't drift), maps each phoneme to
a viseme and a jaw opening (:mod:`~mpeg4fba.speech.phonemes`, package data) and turns
them into a FAP stream with coarticulation (:mod:`~mpeg4fba.speech.coarticulation`).
Needs the ``speech`` extra: ``pip install "mpeg4fba[speech]"``.  Knows the standard
(:mod:`mpeg4fba.fba`) only: writing the audio and the animation is the caller's.

>>> from mpeg4fba.speech import say
>>> u = say("Hello")                                        # doctest: +SKIP
>>> u.stream.fps, abs(u.stream.duration - u.duration) <= 1 / u.stream.fps   # doctest: +SKIP
(25.0, True)
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from ..fba.stream import FapStream
from ..fba.tables import EXPRESSIONS
from .coarticulation import JAW, TRANSITION, phoneme_stream, segments
from .engine import (MAX_TEXT, RATES, PhonemeEvent, SpeechError, SpeechUnavailable, Synthesis,
                     available, list_voices, synthesize)
from .life import with_blinks_and_head
from .phonemes import PhonemeShape, phoneme_shape, phoneme_table

__all__ = ["say", "Utterance", "synthesize", "Synthesis", "PhonemeEvent", "SpeechError",
           "SpeechUnavailable", "available", "list_voices", "phoneme_stream", "segments",
           "phoneme_shape", "phoneme_table", "PhonemeShape", "TRANSITION", "JAW", "MAX_TEXT",
           "RATES", "with_blinks_and_head"]


@dataclass
class Utterance:
    """What :func:`say` gives: the ``stream`` (FAP 1 visemes, FAP 3 jaw, FAP 2 when an
    expression is held), the audio (int16 ``samples`` at ``sample_rate``) and the
    ``phonemes`` they were made from."""

    text: str
    stream: FapStream
    samples: np.ndarray
    sample_rate: int
    phonemes: list

    @property
    def duration(self) -> float:
        """Seconds of audio."""
        return len(self.samples) / self.sample_rate


def say(text: str, *, voice: str = "en", rate: int = 175, fps: float = 25.0,
        expression: Union[int, str, None] = None, intensity: int = 40,
        transition: float = TRANSITION, jaw: float = JAW,
        pitch: Optional[int] = None, life: bool = True) -> Utterance:
    """Speak ``text``: the FAP stream and the audio samples, in step.

    ``voice``: an eSpeak NG language or voice (``en``, ``en-us``, ``fr``...; the
    phoneme table is English, other languages' phonemes go through its fallback rule);
    ``rate`` words a minute; ``fps`` of the stream; ``expression`` (a number 0-6 or a
    name: ``joy``) held through the phrase at ``intensity`` (0-63); ``transition``
    seconds of each viseme's blend; ``jaw`` the open_jaw value of the widest vowel;
    ``life``: blinks and a little head motion too (:mod:`~mpeg4fba.speech.life`, their
    times drawn from the text).  eSpeak's timing varies by some milliseconds from one
    synthesis to the next, so two calls may differ by that; the sound and the stream of
    one call always agree.
    """
    if expression is not None:
        try:
            expression = EXPRESSIONS[expression].number
        except KeyError as e:
            raise SpeechError(str(e.args[0])) from None
    if not 0 <= int(intensity) <= 63:
        raise SpeechError(f"intensity {intensity}: 0 to 63")
    if not 0 < fps <= 1000:
        raise SpeechError(f"fps {fps}: above 0 and at most 1000")
    s = synthesize(text, voice=voice, rate=rate, pitch=pitch)
    stream = phoneme_stream(s.phonemes, s.sample_rate, len(s.samples), fps=fps,
                            transition=transition, jaw=jaw, expression=expression,
                            intensity=intensity, name=" ".join(text.split())[:60])
    if life:
        stream = with_blinks_and_head(stream, seed=zlib.crc32(text.encode("utf-8")))
    return Utterance(text, stream, s.samples, s.sample_rate, s.phonemes)
