"""``mpeg4fba say "TEXT" [FACE] -o OUT``: a face speaks a sentence, with sound.

eSpeak NG speaks TEXT; its phonemes, at their exact sample positions, become visemes
with coarticulation (FAP 1), a jaw that follows the vowels (FAP 3) and, with
``--expression``, an expression held through the phrase (FAP 2); blinks and a little
head motion unless ``--still``.  FACE (default: the reference head) plays it.  OUT by its extension:

* ``OUT.html``: the player with the sound inside (one file, works from file://);
* ``OUT.glb`` / ``OUT.gltf`` and ``OUT.wav`` beside it;
* ``OUT.fap`` and ``OUT.wav`` beside it;
* ``OUT.wav``: the sound alone;
* ``OUT/`` (a name without an extension): PNG frames and ``speech.wav`` in the folder.

Needs the speech extra: ``pip install "mpeg4fba[speech]"``.
"""
from __future__ import annotations

import os
from typing import Optional

import click

from . import main, warnings_to_stderr
from .common import check_output, check_output_folder
from .play import is_folder_output, load_face_arg, png_options

__all__ = ["say", "wav_beside"]

_ANIMATIONS = (".glb", ".gltf", ".fap")


def wav_beside(output: str) -> str:
    """The WAV written beside an animation: ``talk.glb`` -> ``talk.wav``.

    >>> wav_beside("out/talk.glb"), wav_beside("frames")
    ('out/talk.wav', 'frames/speech.wav')
    """
    root, ext = os.path.splitext(output)
    if not ext:
        return os.path.join(output, "speech.wav")
    return root + ".wav"


@main.command(epilog="\b\nExamples:\n  mpeg4fba say \"Hello, I am a cloned face.\" -o hello.html"
                     "\n  mpeg4fba say \"Guten Tag\" face.wrl --voice de -o tag.glb"
                     "\n  mpeg4fba say \"What a day\" --expression joy --intensity 40 -o day.html"
                     "\n  mpeg4fba say \"One two three\" -o frames/")
@click.argument("text")
@click.argument("face", required=False)
@click.option("-o", "--output", required=True, metavar="OUT",
              help="OUT.html (player with sound), OUT.glb/.gltf or OUT.fap (+ OUT.wav), "
                   "OUT.wav, or a folder for PNG frames (+ speech.wav).")
@click.option("--voice", default="en", show_default=True,
              help="An eSpeak NG language or voice: en, en-us, de, fr, ...")
@click.option("--rate", type=click.IntRange(80, 450), default=175, show_default=True,
              help="Words a minute.")
@click.option("--fps", type=click.FloatRange(1, 240), default=25.0, show_default=True,
              help="Frames a second of the animation.")
@click.option("--expression", metavar="NAME|N", help="An expression held through the phrase (joy, 1...).")
@click.option("--intensity", type=click.IntRange(0, 63), default=40, show_default=True,
              help="Its intensity, 0-63.")
@click.option("--still", is_flag=True, help="No blinks or head motion: the mouth alone moves.")
@png_options
def say(text: str, face: Optional[str], output: str, voice: str, rate: int, fps: float,
        expression: Optional[str], intensity: int, still: bool, frames: Optional[str],
        size: str, view: str) -> None:
    """Speak TEXT on FACE (default: the reference head), with sound."""
    from ..speech import SpeechUnavailable

    low = output.lower()
    folder = is_folder_output(output)
    inputs = [(face, "FACE")]
    if folder:
        check_output_folder(output, inputs)
    else:
        check_output(output, inputs, suffixes=_ANIMATIONS + (".html", ".wav"), what="speech",
                     note=" (or PNG frames into a folder: a name without an extension)")
        if low.endswith(_ANIMATIONS):
            check_output(wav_beside(output), inputs + [(output, "-o")], suffixes=(".wav",),
                         what="the sound")
    try:
        from ..speech import say as speak
        with warnings_to_stderr():
            u = speak(text, voice=voice, rate=rate, fps=fps, expression=expression,
                      intensity=intensity, life=not still)
    except SpeechUnavailable as e:
        raise click.ClickException(str(e)) from None
    from ..formats.wav import dumps_wav, write_wav

    stream = u.stream
    written = []
    if low.endswith(".wav") and not folder:
        write_wav(u.samples, u.sample_rate, output)
        written.append(output)
    elif low.endswith(".fap"):
        from ..formats.fap import write_fap
        write_fap(stream, output)
        write_wav(u.samples, u.sample_rate, wav_beside(output))
        written += [output, wav_beside(output)]
    else:
        with warnings_to_stderr():
            head = load_face_arg(face, face is None)
        if low.endswith((".glb", ".gltf")):
            from ..formats.gltf import write_glb
            write_glb(head, output, stream)
            write_wav(u.samples, u.sample_rate, wav_beside(output))
            written += [output, wav_beside(output)]
        elif low.endswith(".html") and not folder:
            from ..formats.gltf import dumps_glb
            from ..render.player import write_player
            write_player(dumps_glb(head, stream), output, title=f"{head.name}: \u201c{text}\u201d",
                         audio=dumps_wav(u.samples, u.sample_rate))
            written.append(output)
        else:
            from .play import frame_range, png_frames
            png_frames(head, stream, output, frame_range(frames, len(stream)), size, view)
            write_wav(u.samples, u.sample_rate, wav_beside(output))
            written.append(wav_beside(output))
    click.echo(f"said {len(u.text.split())} words in {u.duration:.2f} s: {len(stream)} frames at "
               f"{stream.fps:g} fps, {len(u.phonemes)} phonemes; wrote {', '.join(written)}")
