"""eSpeak NG as the speech engine: the audio and the phoneme events of one synthesis.

The library and its voice data come from the ``espeakng-loader`` wheel (the ``speech``
extra: no system install, no network) and are driven through ``ctypes``.  Synthesis is
synchronous: eSpeak hands over each block of samples together with the events that
fall in it, and each phoneme event carries its position in samples, so the phonemes'
times are those of the sound itself and the two cannot drift.

>>> s = synthesize("papa")                                   # doctest: +SKIP
>>> [p.name for p in s.phonemes][:4], s.sample_rate         # doctest: +SKIP
(['p', 'a#', 'p', "'A:"], 22050)
"""
from __future__ import annotations

import ctypes
import threading
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

__all__ = ["synthesize", "Synthesis", "PhonemeEvent", "SpeechUnavailable", "SpeechError",
           "available", "list_voices", "MAX_TEXT", "RATES"]

#: Longest text synthesised at once (characters): about an hour of speech.
MAX_TEXT = 50_000
#: eSpeak's speaking rates, words per minute.
RATES = (80, 450)

# speak_lib.h
_SYNCHRONOUS = 2
_PHONEME_EVENTS, _DONT_EXIT = 0x0001, 0x8000
_EV_END, _EV_WORD, _EV_PHONEME = 0, 1, 7
_POS_CHARACTER, _CHARS_UTF8 = 1, 1
_RATE, _PITCH = 1, 3


class SpeechUnavailable(ImportError):
    """The speech engine is not installed (the ``speech`` extra)."""


class SpeechError(ValueError):
    """Text, voice or rate the engine can't take."""


class _Id(ctypes.Union):
    _fields_ = [("number", ctypes.c_int), ("name", ctypes.c_char_p), ("string", ctypes.c_char * 8)]


class _Event(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int), ("unique_identifier", ctypes.c_uint),
                ("text_position", ctypes.c_int), ("length", ctypes.c_int),
                ("audio_position", ctypes.c_int), ("sample", ctypes.c_int),
                ("user_data", ctypes.c_void_p), ("id", _Id)]


class _Voice(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("languages", ctypes.c_char_p),
                ("identifier", ctypes.c_char_p), ("gender", ctypes.c_ubyte),
                ("age", ctypes.c_ubyte), ("variant", ctypes.c_ubyte), ("xx1", ctypes.c_ubyte),
                ("score", ctypes.c_int), ("spare", ctypes.c_void_p)]


_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int,
                             ctypes.POINTER(_Event))


@dataclass(frozen=True)
class PhonemeEvent:
    """One phoneme as eSpeak spoke it: ``name`` its mnemonic with stress marks
    (``'A:``, ``p``, ``_`` for a pause), ``sample`` where it starts in the audio,
    ``word`` the number of the word it belongs to (from 1), ``text_position`` the
    character of the text (from 1)."""

    name: str
    sample: int
    word: int
    text_position: int


@dataclass
class Synthesis:
    """The audio (int16 mono ``samples`` at ``sample_rate``) and its ``phonemes`` in
    order, from one synthesis of ``text`` with ``voice``."""

    text: str
    voice: str
    sample_rate: int
    samples: np.ndarray
    phonemes: list = field(default_factory=list)

    @property
    def duration(self) -> float:
        """Seconds of audio."""
        return len(self.samples) / self.sample_rate


class _Engine:
    """The loaded library, initialised once per process; one synthesis at a time."""

    def __init__(self):
        try:
            import espeakng_loader
        except ImportError:
            raise SpeechUnavailable('speech needs eSpeak NG: pip install "mpeg4fba[speech]"') from None
        self.lock = threading.Lock()
        self.lib = ctypes.CDLL(espeakng_loader.get_library_path())
        self.lib.espeak_Initialize.restype = ctypes.c_int
        self.lib.espeak_ListVoices.restype = ctypes.POINTER(ctypes.POINTER(_Voice))
        data = espeakng_loader.get_data_path().encode()
        self.sample_rate = self.lib.espeak_Initialize(_SYNCHRONOUS, 0, data,
                                                      _PHONEME_EVENTS | _DONT_EXIT)
        if self.sample_rate <= 0:
            raise SpeechUnavailable(f"eSpeak NG did not start (data in {data.decode()})")
        self._chunks: list = []
        self._events: list = []
        # kept on the object: ctypes must not free the callback while eSpeak holds it
        self._callback = _CALLBACK(self._receive)
        self.lib.espeak_SetSynthCallback(self._callback)

    def _receive(self, wav, n: int, events) -> int:
        if n > 0:
            self._chunks.append(np.ctypeslib.as_array(wav, (n,)).copy())
        i = 0
        while events[i].type != _EV_END:
            e = events[i]
            if e.type == _EV_PHONEME:
                self._events.append(("p", e.id.string.decode("utf-8", "replace"), e.sample,
                                     e.text_position))
            elif e.type == _EV_WORD:
                self._events.append(("w", e.id.number, e.sample, e.text_position))
            i += 1
        return 0

    def voices(self) -> list:
        out, p = [], self.lib.espeak_ListVoices(None)
        i = 0
        while p[i]:
            v = p[i].contents
            out.append((v.name.decode("utf-8", "replace"), v.identifier.decode("utf-8", "replace"),
                        v.languages[1:].split(b"\0")[0].decode("utf-8", "replace")))
            i += 1
        return out

    def synthesize(self, text: str, voice: str, rate: int, pitch: Optional[int]) -> Synthesis:
        with self.lock:
            if self.lib.espeak_SetVoiceByName(voice.encode()) != 0:
                known = sorted({lang for _, _, lang in self.voices()})
                raise SpeechError(f"eSpeak NG has no voice {voice!r}; languages: "
                                  f"{', '.join(known[:40])}{' ...' if len(known) > 40 else ''}")
            self.lib.espeak_SetParameter(_RATE, int(rate), 0)
            if pitch is not None:
                self.lib.espeak_SetParameter(_PITCH, int(pitch), 0)
            self._chunks, self._events = [], []
            data = text.encode("utf-8") + b"\0"
            self.lib.espeak_Synth(data, len(data), 0, _POS_CHARACTER, 0, _CHARS_UTF8, None, None)
            self.lib.espeak_Synchronize()
            chunks, events = self._chunks, self._events
            self._chunks, self._events = [], []
        samples = np.concatenate(chunks) if chunks else np.zeros(0, np.int16)
        phonemes, word = [], 0
        for kind, value, sample, pos in events:
            if kind == "w":
                word = int(value)
            else:
                phonemes.append(PhonemeEvent(value, int(sample), word, int(pos)))
        return Synthesis(text, voice, self.sample_rate, samples.astype(np.int16, copy=False),
                         phonemes)


_engine: Optional[_Engine] = None
_engine_lock = threading.Lock()


def _get() -> _Engine:
    global _engine
    with _engine_lock:
        if _engine is None:
            _engine = _Engine()
        return _engine


def available() -> bool:
    """Whether the speech engine is installed."""
    try:
        _get()
    except SpeechUnavailable:
        return False
    return True


def list_voices() -> list:
    """(name, identifier, language) of every voice eSpeak NG has."""
    return _get().voices()


def synthesize(text: str, *, voice: str = "en", rate: int = 175,
               pitch: Optional[int] = None) -> Synthesis:
    """Speak ``text`` with eSpeak NG: its audio and its phonemes at their samples.

    ``voice`` is a language or voice name eSpeak knows (``en``, ``en-us``, ``de``...),
    ``rate`` words per minute (:data:`RATES`), ``pitch`` 0-100 (eSpeak's default 50).
    """
    if not isinstance(text, str) or not text.strip():
        raise SpeechError("nothing to say: the text is empty")
    if len(text) > MAX_TEXT:
        raise SpeechError(f"a text of {len(text)} characters is more than the {MAX_TEXT} "
                          "spoken at once; split it")
    if not RATES[0] <= rate <= RATES[1]:
        raise SpeechError(f"rate {rate}: eSpeak speaks {RATES[0]} to {RATES[1]} words a minute")
    if pitch is not None and not 0 <= pitch <= 100:
        raise SpeechError(f"pitch {pitch}: 0 to 100")
    # eSpeak reads SSML-like markup only when asked; control characters it may choke on
    clean = "".join(c if c.isprintable() or c in "\n\t" else " " for c in text)
    return _get().synthesize(clean, voice, rate, pitch)
