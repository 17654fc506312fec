#!/usr/bin/env python
"""Speech from text (issue 23): seconds of speech made per second of compute, and the
player's size per second of speech.

    python benchmarks/bench_speech.py [--repeat N]

For texts of one sentence to a paragraph, times ``mpeg4fba.speech.say`` (eSpeak NG's
synthesis with its phoneme events, the viseme table, coarticulation into the FAP
stream) and, apart, what writing the results costs: the WAV, and the HTML player with
the reference head, the animation and the sound inside.  Best of ``--repeat`` (3)
after a warm-up (the engine loads once per process: its first call is printed apart).
Issue 23's goal: 50x real time for text -> stream + audio.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

TEXTS = {
    "sentence": "Hello! I am a cloned face.",
    "two sentences": "The quick brown fox jumps over the lazy dog. She sells sea shells by the sea shore.",
    "paragraph": ("Facial animation driven by speech is the classic use of MPEG-4 face and body "
                  "animation. A face model carries a table for every viseme, and a stream of "
                  "parameters tells it which to show, frame by frame, while the sound plays. "
                  "Here the speech engine gives the sound and the time of every phoneme from "
                  "one synthesis, so the mouth and the voice stay together from the first word "
                  "to the last, however long the text."),
}


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from mpeg4fba.formats.gltf import dumps_glb
    from mpeg4fba.formats.wav import dumps_wav
    from mpeg4fba.models import reference_head
    from mpeg4fba.render.player import player_html
    from mpeg4fba.speech import say

    t = time.perf_counter()
    say("Hello")
    first = time.perf_counter() - t
    face = reference_head()
    base = len(player_html(dumps_glb(face), title="face").encode("utf-8")) / 1e6
    print(f"# engine start-up and first call: {first:.3f} s; the player of the still "
          f"reference head alone: {base:.2f} MB")
    print("\n| text | speech (s) | say: compute (s) | x real time | player (MB) | "
          "MB per s of speech beyond the still face | of it sound |")
    print("|---|---|---|---|---|---|---|")
    for name, text in TEXTS.items():
        u = say(text)
        took = best(lambda: say(text), args.repeat)
        wav = dumps_wav(u.samples, u.sample_rate)
        page = player_html(dumps_glb(face, u.stream), title=name, audio=wav)
        size = len(page.encode("utf-8")) / 1e6
        print(f"| {name} ({len(text.split())} words) | {u.duration:.2f} | {took:.4f} | "
              f"{u.duration / took:.0f}x | {size:.2f} | {(size - base) / u.duration:.3f} | "
              f"{len(wav) * 4 / 3 / 1e6 / u.duration:.3f} |")


if __name__ == "__main__":
    main()
