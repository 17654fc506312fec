"""``mpeg4fba play FACE STREAM -o OUT``: a FAP stream played on a face, written as

* ``OUT.glb`` / ``OUT.gltf``: glTF 2.0, one morph target per FAT interval, the stream as
  an animation of morph weights and Transform rotations (exact);
* ``OUT.wrl`` / ``OUT.wrl.gz``: VRML97 with TimeSensor, Coordinate/Orientation/Position
  interpolators and ROUTEs, for any VRML97 browser;
* ``OUT.html``: the self-contained HTML player (three.js inside, works from file://);
* ``OUT/`` (a name without an extension, one ending in ``/``, or an existing folder): a
  folder of PNG frames, ``frame_0000.png``...; another extension (``talk.mp4``) is
  refused rather than taken for a folder.

The output is checked before any work: not one of the inputs (also through links), its
folder there and writable.

FACE is a VRML face (or the reference head with ``--example``); STREAM a ``.fap`` file
(or the demo phrase with ``--demo-stream``).

Example
-------
>>> import os, tempfile
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> d = tempfile.mkdtemp()
>>> r = CliRunner().invoke(main, ["play", "--example", "--demo-stream", "--frames", "0:3",
...                               "-o", os.path.join(d, "frames")])
>>> r.exit_code, sorted(os.listdir(os.path.join(d, "frames")))
(0, ['frame_0000.png', 'frame_0001.png', 'frame_0002.png'])
"""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Optional

import click

from . import main, warnings_to_stderr
from .common import check_output, check_output_folder

__all__ = ["play", "load_face_arg", "load_stream_arg", "parse_size", "png_options", "png_frames",
           "frame_range", "is_folder_output"]

_GLTF = (".glb", ".gltf")
_VRML = (".wrl", ".wrz", ".wrl.gz")


def load_face_arg(path: Optional[str], example: bool, points: Optional[str] = None,
                  lenient: bool = False):
    """The FACE argument of a subcommand: a face file, or the reference head."""
    if example == (path is not None):
        raise click.UsageError("give either FACE or --example")
    if example:
        from ..models import reference_head
        return reference_head()
    from ..formats.face_files import read_face
    return read_face(path, points, lenient=lenient)


def load_stream_arg(path: Optional[str], demo: bool):
    """The STREAM argument: a .fap file, or the demo phrase."""
    if demo == (path is not None):
        raise click.UsageError("give either STREAM or --demo-stream")
    if demo:
        from ..models.phrase import demo_stream
        return demo_stream()
    from ..formats.fap import read_fap
    return read_fap(path)


MAX_SIDE = 8192


def parse_size(size: str) -> tuple:
    """(width, height) from a ``--size`` value such as ``480x560``."""
    try:
        w, h = (int(v) for v in size.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{size!r}: expected WIDTHxHEIGHT, e.g. 480x560",
                                 param_hint="--size") from None
    if not (1 <= w <= MAX_SIDE and 1 <= h <= MAX_SIDE):
        # refused before any pixel is allocated: 100000x100000 would be 40 GB
        raise click.BadParameter(f"{size!r}: each side from 1 to {MAX_SIDE} pixels",
                                 param_hint="--size")
    return w, h


def is_folder_output(output: str) -> bool:
    """Whether ``-o`` names a folder (of PNG frames): no extension, a trailing slash, or
    an existing folder.

    >>> is_folder_output("frames"), is_folder_output("frames/"), is_folder_output("a.glb")
    (True, True, False)
    """
    return (not os.path.splitext(output)[1] or output.endswith(("/", os.sep))
            or os.path.isdir(output))


def frame_range(spec: Optional[str], n: int) -> range:
    """The frames a ``--frames FIRST:LAST`` value picks of ``n``.

    >>> frame_range("2:5", 10), frame_range(None, 3), frame_range(":2", 10)
    (range(2, 5), range(0, 3), range(0, 2))
    """
    if spec is None:
        return range(n)
    try:
        a, _, b = spec.partition(":")
        first = int(a) if a else 0
        last = int(b) if b else n
    except ValueError:
        raise click.BadParameter(f"{spec!r}: expected FIRST:LAST frame numbers, e.g. 0:50") from None
    if not 0 <= first < last <= n:
        raise click.BadParameter(f"{spec!r}: the stream has frames 0 to {n - 1}")
    return range(first, last)


def png_options(f):
    """The PNG frame options of ``play`` and ``batch play``: --frames, --size, --view."""
    f = click.option("--view", default="front", show_default=True,
                     type=click.Choice(["front", "three-quarter", "profile"]), help="PNG camera.")(f)
    f = click.option("--size", default="480x560", show_default=True, metavar="WxH",
                     help="PNG frame size.")(f)
    return click.option("--frames", metavar="FIRST:LAST",
                        help="PNG frames only: which frames (default all).")(f)


@main.command(epilog="\b\nExamples:\n  mpeg4fba play face.wrl talk.fap -o talk.glb"
                     "\n  mpeg4fba play face.wrl talk.fap -o talk.html"
                     "\n  mpeg4fba play face.wrl talk.fap -o talk.wrl"
                     "\n  mpeg4fba play --example --demo-stream -o frames/")
@click.argument("files", nargs=-1, metavar="FACE STREAM")
@click.option("-o", "--output", required=True, metavar="OUT",
              help="OUT.glb, OUT.gltf, OUT.wrl, OUT.html, or a folder for PNG frames.")
@click.option("--example", is_flag=True, help="Play on the reference head instead of FACE.")
@click.option("--demo-stream", is_flag=True, help="Play the built-in demo phrase instead of STREAM.")
@png_options
def play(files: tuple, output: str, example: bool, demo_stream: bool, frames: Optional[str],
         size: str, view: str) -> None:
    """Play STREAM on FACE and write the animation (the output's extension says how)."""
    files = list(files)
    face_path = None if example else (files.pop(0) if files else None)
    stream_path = None if demo_stream else (files.pop(0) if files else None)
    if files:
        raise click.UsageError(f"unexpected argument {files[0]!r}")
    low = output.lower()
    inputs = [(face_path, "FACE"), (stream_path, "STREAM")]
    folder = is_folder_output(output)
    if folder:
        check_output_folder(output, inputs)
    else:  # "talk.mp4" is more likely a mistake than the name of a folder of frames
        check_output(output, inputs, suffixes=_GLTF + _VRML + (".html",), what="an animation",
                     note=" (or PNG frames into a folder: a name without an extension, or "
                          "ending in /)")
    with warnings_to_stderr():
        face = load_face_arg(face_path, example)
        stream = load_stream_arg(stream_path, demo_stream)
        if low.endswith(_GLTF):
            from ..formats.gltf import write_glb
            write_glb(face, output, stream)
        elif low.endswith(_VRML):
            from ..formats.wrl_anim import write_animated_wrl
            write_animated_wrl(face, stream, output)
        elif low.endswith(".html"):
            from ..formats.gltf import dumps_glb
            from ..render.player import write_player
            write_player(dumps_glb(face, stream), output, title=f"{face.name}: {stream.name or 'stream'}")
        else:
            png_frames(face, stream, output, frame_range(frames, len(stream)), size, view)
            return
    click.echo(f"wrote {output}: {len(stream)} frames at {stream.fps:g} fps on {face.name}")


def png_frames(face, stream, folder: str, frames: range, size: str, view: str) -> None:
    """Render ``frames`` of ``stream`` on ``face`` as ``folder/frame_0000.png``..."""
    from ..render.preview import render_face, save_png

    w, h = parse_size(size)
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    playback = face.play(stream)
    with click.progressbar(frames, label="rendering frames", file=sys.stderr,
                           show_pos=True) as bar:
        for i in bar:
            save_png(out / f"frame_{i:04d}.png",
                     render_face(face, playback, frame=i, size=(w, h), view=view))
    click.echo(f"wrote {len(frames)} PNG frames to {os.fspath(out)}")
