"""``mpeg4fba render``: pictures of faces.

* ``mpeg4fba render FACE -o face.png [--fap open_jaw=600 ...] [--viseme N] [--expression N]``:
  one picture, neutral or posed;
* ``--turntable N``: N pictures round the face (yaw 0 to 360), tiled into one image;
* ``--grid FACE2 [FACE3...]``: a cloning grid (rows: sources, columns: targets, each
  face cloned onto each other; the faces need FATs or get them by cloning from the
  first) in the given pose.

Example
-------
>>> import os, tempfile
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> out = os.path.join(tempfile.mkdtemp(), "joy.png")
>>> r = CliRunner().invoke(main, ["render", "--example", "--expression", "1", "--size", "120x140",
...                               "-o", out])
>>> r.exit_code, os.path.getsize(out) > 0
(0, True)
"""
from __future__ import annotations

from typing import Optional

import click

from . import main, warnings_to_stderr
from .play import load_face_arg, parse_size

__all__ = ["render"]


def _pose(faps: tuple, viseme: Optional[int], expression: Optional[int]) -> dict:
    from ..fba.tables import FAP

    values = {}
    for item in faps:
        name, sep, value = item.partition("=")
        if not sep:
            raise click.BadParameter(f"{item!r}: expected NAME=VALUE, e.g. open_jaw=600",
                                     param_hint="--fap")
        try:
            number = FAP[int(name)].number if name.strip().isdigit() else FAP[name.strip()].number
            values[number] = float(value)
        except (KeyError, ValueError) as e:
            raise click.BadParameter(f"{item!r}: {e}", param_hint="--fap") from None
    pose = {"faps": values}
    if viseme is not None:
        pose["visemes"] = (viseme, 0, 63, 0)
    if expression is not None:
        pose["expressions"] = (expression, 63, 0, 0, 0, 0)
    return pose


@main.command(epilog="\b\nExamples:\n  mpeg4fba render face.wrl -o face.png"
                     "\n  mpeg4fba render face.wrl --fap open_jaw=800 --expression 1 -o joy.png"
                     "\n  mpeg4fba render face.wrl --turntable 8 -o turntable.png"
                     "\n  mpeg4fba render --example --grid other.wrl --viseme 12 -o grid.png")
@click.argument("face", required=False)
@click.option("-o", "--output", required=True, metavar="OUT.png", help="The PNG to write.")
@click.option("--example", is_flag=True, help="Render the reference head instead of FACE.")
@click.option("--fap", "faps", multiple=True, metavar="NAME=VALUE",
              help="A low-level FAP value (name or number); repeatable.")
@click.option("--viseme", type=click.IntRange(0, 14), help="A viseme (1-14) at full strength.")
@click.option("--expression", type=click.IntRange(0, 6), help="An expression (1-6) at full intensity.")
@click.option("--view", default="front", show_default=True,
              type=click.Choice(["front", "three-quarter", "profile"]))
@click.option("--size", default="480x560", show_default=True, metavar="WxH")
@click.option("--turntable", type=click.IntRange(2, 72), metavar="N",
              help="N views round the face, tiled into one image.")
@click.option("--grid", "grid", multiple=True, metavar="FACE",
              help="More faces for a cloning grid with FACE; repeatable.")
def render(face: Optional[str], output: str, example: bool, faps: tuple, viseme: Optional[int],
           expression: Optional[int], view: str, size: str, turntable: Optional[int],
           grid: tuple) -> None:
    """Render FACE (neutral or posed) to a PNG: one view, a turntable or a cloning grid."""
    from ..render.preview import render_face, render_grid, save_png

    w, h = parse_size(size)
    pose = _pose(faps, viseme, expression)
    with warnings_to_stderr():
        subject = load_face_arg(face, example)
        if grid:
            image = _grid(subject, grid, pose, (w, h), view)
        elif turntable:
            frames = subject.pose(pose["faps"], pose.get("visemes"), pose.get("expressions"))
            yaws = [360.0 * k / turntable for k in range(turntable)]
            images = [render_face(subject, frames, size=(w, h), view=(yaw, 5.0)) for yaw in yaws]
            image = render_grid(images, [f"{yaw:.0f}\u00b0" for yaw in yaws],
                                cols=min(turntable, 6))
        else:
            frames = subject.pose(pose["faps"], pose.get("visemes"), pose.get("expressions"))
            image = render_face(subject, frames, size=(w, h), view=view)
        save_png(output, image)
    click.echo(f"wrote {output} ({image.shape[1]}x{image.shape[0]})")


def _grid(first, others: tuple, pose: dict, size: tuple, view: str):
    import warnings

    from ..cloning import CloneWarning, clone
    from ..fba.fat import FAT
    from ..formats.face_files import read_face
    from ..render.grid import cloning_grid

    faces = [first] + [read_face(p) for p in others]
    if not len(first.fat):
        raise click.ClickException(f"the first face of a grid ({first.name}) needs a FAT")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloneWarning)
        for k in range(1, len(faces)):
            if not len(faces[k].fat):
                target = faces[k]
                target.fat = FAT()
                faces[k] = clone(first, target)
    return cloning_grid(faces, pose, size=size, view=view)
