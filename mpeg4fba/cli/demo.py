"""``mpeg4fba demo OUT_DIR``: the whole job on built-in faces, no input files.

Builds the reference head (the source, with its FAT) and a head of other proportions
and another mesh (the target, no FAT), clones every FAP, viseme and expression onto the
target, validates the result (numeric FAP check included) and writes into OUT_DIR:

* ``target.wrl``: the target with its new FAT (VRML97 with the MPEG-4 nodes as PROTOs);
* ``target.glb``: the same as glTF, animated by the demo phrase, "Hello! I am a cloned
  face." (visemes, an arc of joy, blinks, head motion): spoken by eSpeak NG where the
  speech extra is installed (:mod:`mpeg4fba.speech`), else the silent, hand-timed
  ``mpeg4fba/models/data/demo_phrase.fap``;
* ``demo_phrase.fap``: that stream, and ``demo_phrase.wav`` its sound when spoken;
* ``preview.png``: both heads neutral, in the six expressions, in four visemes and in a
  combination of low-level FAPs;
* ``player.html``: the animated target in the browser, with the sound when spoken (one
  file, works from file://);
* ``report.txt``: what was done, the validation and the timings.

Example
-------
>>> import os, tempfile
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> d = tempfile.mkdtemp()
>>> r = CliRunner().invoke(main, ["demo", d, "--quick"])
>>> r.exit_code, sorted(set(os.listdir(d)) - {"demo_phrase.wav"})
(0, ['demo_phrase.fap', 'player.html', 'preview.png', 'report.txt', 'target.glb', 'target.wrl'])
"""
from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import click

from .._atomic import atomic_write
from . import main
from .common import check_output_folder

__all__ = ["demo", "demo_phrase"]

#: The target's proportions (see :func:`mpeg4fba.models.reference_head`).
TARGET = dict(face_width=1.15, jaw=0.9, nose=1.12, eye_spacing=1.08, mouth_width=0.9, seed=11)
PREVIEW_VISEMES = (1, 2, 10, 13)           # PP, FF, aa, oh
#: The low-level FAP values of Pandzic's Fig. 13: jaw open, lip corners stretched, every
#: lip raise/lower FAP at -400, the left eyebrow raised.
FIG13_FAPS = {3: 800, 53: 150, 54: 150, 31: 300, 33: 300, 35: 300,
              **{f: -400 for f in (4, 5, 8, 9, 10, 11, 51, 52, 55, 56, 57, 58)}}


@main.command(epilog="\b\nExamples:\n  mpeg4fba demo demo-out\n  mpeg4fba demo demo-out --quick")
@click.argument("out_dir", type=click.Path(file_okay=False))
@click.option("--quick", is_flag=True, help="Coarser heads and smaller pictures (for a fast look).")
def demo(out_dir: str, quick: bool) -> None:
    """Clone the reference head's motion onto another head and write what it makes."""
    from ..cloning import CloneWarning, FacialMotionCloner
    from ..fba.fat import FAT
    from ..formats.fap import write_fap
    from ..formats.gltf import write_glb
    from ..formats.validate import validate
    from ..formats.wrl_face import save_face
    from ..models import reference_head
    from ..models.phrase import PHRASE_TEXT
    from ..render.player import write_player

    check_output_folder(out_dir, hint="OUT_DIR")  # before the work, not after it
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res = (0.5, 0.6) if quick else (1.0, 0.8)
    times: dict = {}
    state: dict = {}
    notes: list = []

    def build():
        state["source"] = reference_head(resolution=res[0])
        target = reference_head(resolution=res[1], **TARGET)
        target.fat = FAT()
        target.name = "target_head"
        state["target"] = target

    def clone():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", CloneWarning)
            t0 = time.perf_counter()
            cloner = FacialMotionCloner(state["source"], state["target"])
            times["mapping"] = time.perf_counter() - t0
            state["result"] = cloner.clone()
        notes.extend(str(w.message) for w in caught)

    def check():
        state["report"] = validate(state["result"])

    def write():
        stream, wav = demo_phrase()
        state["stream"], state["spoken"] = stream, wav is not None
        save_face(state["result"], out / "target.wrl")
        write_glb(state["result"], out / "target.glb", stream)
        write_fap(stream, out / "demo_phrase.fap")
        if wav is not None:
            atomic_write(out / "demo_phrase.wav", wav)
        write_player((out / "target.glb").read_bytes(), out / "player.html",
                     title=f"mpeg4fba demo: \u201c{PHRASE_TEXT}\u201d", audio=wav)

    def preview():
        _preview(state["source"], state["result"], out / "preview.png", quick)

    steps = [("building the heads", build), ("cloning the motion", clone),
             ("validating the result", check), ("writing VRML, glTF, the player", write),
             ("rendering the preview", preview)]
    with click.progressbar(steps, label="mpeg4fba demo", file=sys.stderr,
                           item_show_func=lambda s: s[0] if s else "") as bar:
        for label, step in bar:
            t0 = time.perf_counter()
            step()
            times[label] = time.perf_counter() - t0

    report = state["report"]
    result = state["result"]
    lines = _report(state["source"], result, report, times, notes, state["stream"],
                    state["spoken"])
    atomic_write(out / "report.txt", "\n".join(lines) + "\n")
    click.echo("\n".join(lines[:4]))
    click.echo(f"\nwritten to {out.resolve()}:")
    for name, what in (("target.wrl", "the cloned face, FAT-bearing VRML97"),
                       ("target.glb", "the same as glTF, animated by the demo phrase"),
                       ("player.html", "open it in a browser to watch it talk"),
                       ("preview.png", "both heads: neutral, six expressions, four visemes, low-level FAPs"),
                       ("demo_phrase.fap", "the FAP stream")) + ((
                       ("demo_phrase.wav", "its sound (eSpeak NG), also inside player.html"),)
                       if state["spoken"] else ()) + (
                       ("report.txt", "validation and timings"),):
        click.echo(f"  {name:16s} {what}")
    if not report.ok:
        raise click.ClickException("the cloned face does not pass validation (see report.txt)")


def demo_phrase() -> tuple:
    """(the demo phrase's stream, its WAV bytes or None): spoken by eSpeak NG where the
    speech extra is installed (its visemes and jaw, the demo's expression arc, blinks and
    head motion), else the packaged silent phrase."""
    from ..models.phrase import PHRASE_TEXT, demo_stream, with_life
    try:
        from ..speech import SpeechUnavailable, say
        u = say(PHRASE_TEXT, life=False)     # the demo's own life is added below
    except (ImportError, SpeechUnavailable):
        return demo_stream(), None
    from ..formats.wav import dumps_wav
    stream = with_life(u.stream)
    stream.name = "demo_phrase"
    return stream, dumps_wav(u.samples, u.sample_rate)


def _report(source, result, report, times, notes, stream, spoken: bool) -> list:
    fat = result.fat
    measured = {k: v for k, v in report.ratios.items() if v is not None}
    worst = max((abs(v - 1) for v in measured.values()), default=0.0)
    n_src = sum(len(m.vertices) for m in source.meshes.values())
    n_tgt = sum(len(m.vertices) for m in result.meshes.values())
    lines = [
        f"cloned {len(fat.faps)} FAPs, {len(fat.visemes)} visemes and {len(fat.expressions)} "
        f"expressions from the reference head ({n_src:,} vertices) onto a head of other "
        f"proportions ({n_tgt:,} vertices)",
        f"validation: {'OK' if report.ok else 'FAILED'}, {len(report.errors)} errors, "
        f"{sum(f.severity == 'warning' for f in report.findings)} warnings; numeric FAP check: "
        f"{len(measured)} FAPs measured, largest deviation {worst:.1%}",
        f"time: mapping {times.get('mapping', 0):.2f} s, cloning step "
        f"{times.get('cloning the motion', 0):.2f} s in all",
        f"animation: {len(stream)} frames at {stream.fps:g} fps ({len(stream) / stream.fps:.1f} s), "
        + ("spoken by eSpeak NG, with sound" if spoken else
           'silent (pip install "mpeg4fba[speech]" to hear it spoken)'),
        "",
        "steps (seconds):",
    ]
    lines += [f"  {k}: {v:.2f}" for k, v in times.items() if k != "mapping"]
    if notes:
        lines += ["", "notes from the cloner:"] + [f"  {n}" for n in notes]
    findings = [str(f) for f in report.findings if f.severity != "info"]
    if findings:
        lines += ["", "findings:"] + [f"  {f}" for f in findings]
    return lines


def _preview(source, target, path: Path, quick: bool) -> None:
    from ..fba.tables import EXPRESSIONS, VISEMES
    from ..render.preview import render_face, render_grid, save_png

    size = (150, 176) if quick else (220, 258)
    poses = [("neutral", {})]
    poses += [(e.name, {"expressions": (e.number, 63, 0, 0, 0, 0)}) for e in EXPRESSIONS if e.number]
    poses += [(f"viseme {VISEMES[v].name}", {"visemes": (v, 0, 63, 0)}) for v in PREVIEW_VISEMES]
    poses.append(("low-level FAPs", {"faps": FIG13_FAPS}))
    images, labels = [], []
    for who, face in (("source", source), ("target", target)):
        for name, pose in poses:
            frames = face.pose(pose.get("faps", {}), pose.get("visemes"), pose.get("expressions"))
            images.append(render_face(face, frames, size=size, view="three-quarter"))
            labels.append(f"{who}: {name}")
    save_png(path, render_grid(images, labels, cols=len(poses) // 2))
