"""``mpeg4fba render``: pictures of faces.

* ``mpeg4fba render FACE -o face.png [--fap open_jaw=600 ...] [--viseme aa] [--expression joy]``:
  one picture, neutral or posed (visemes and expressions by number or name; ``-o``
  ending in ``.png``, ``.jpg`` or ``.jpeg`` says the format);
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
>>> r = CliRunner().invoke(main, ["render", "--example", "--expression", "joy", "--size", "120x140",
...                               "-o", out])
>>> r.exit_code, os.path.getsize(out) > 0
(0, True)
"""
from __future__ import annotations

from typing import Optional

import click

from ..fba.tables import EXPRESSIONS, VISEMES
from . import main, warnings_to_stderr
from .common import TableEntry, check_output
from .play import load_face_arg, parse_size

__all__ = ["render"]


_NO_RANGE = 1e5   # for a FAP whose range the table lacks: far past any face's motion


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
        except KeyError as e:  # its message names the nearest FAPs
            raise click.BadParameter(f"{item!r}: {e.args[0]}", param_hint="--fap") from None
        try:
            v = float(value)
        except ValueError:
            raise click.BadParameter(f"{item!r}: {value.strip()!r} is not a number",
                                     param_hint="--fap") from None
        lo, hi = FAP[number].range or (-_NO_RANGE, _NO_RANGE)
        if not lo <= v <= hi:     # also nan and inf; 1e300 would overflow the geometry
            raise click.BadParameter(
                f"{item!r}: {FAP[number].name} takes {lo:g} to {hi:g} (in its FAPU)",
                param_hint="--fap")
        values[number] = v
    pose = {"faps": values}
    if viseme is not None:
        pose["visemes"] = (viseme, 0, 63, 0)
    if expression is not None:
        pose["expressions"] = (expression, 63, 0, 0, 0, 0)
    return pose


@main.command(epilog="\b\nExamples:\n  mpeg4fba render face.wrl -o face.png"
                     "\n  mpeg4fba render face.wrl --fap open_jaw=800 --expression joy -o joy.png"
                     "\n  mpeg4fba render face.wrl --turntable 8 -o turntable.jpg"
                     "\n  mpeg4fba render --example --grid other.wrl --viseme ih -o grid.png")
@click.argument("face", required=False)
@click.option("-o", "--output", required=True, metavar="OUT.png",
              help="The picture to write: .png, or .jpg / .jpeg for JPEG.")
@click.option("--example", is_flag=True, help="Render the reference head instead of FACE.")
@click.option("--fap", "faps", multiple=True, metavar="NAME=VALUE",
              help="A low-level FAP value (name or number); repeatable.")
@click.option("--viseme", type=TableEntry(VISEMES),
              help="A viseme at full strength: 1-14 or its name ("
                   + ", ".join(v.name for v in VISEMES if v.number) + ").")
@click.option("--expression", type=TableEntry(EXPRESSIONS),
              help="An expression at full intensity: 1-6 or its name ("
                   + ", ".join(e.name for e in EXPRESSIONS if e.number) + ").")
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
    """Render FACE (neutral or posed) to a PNG or JPEG: one view, a turntable or a cloning grid."""
    from ..render.preview import IMAGE_SUFFIXES, render_face, render_grid, save_image

    w, h = parse_size(size)
    pose = _pose(faps, viseme, expression)
    check_output(output, [(face, "FACE")] + [(g, "--grid") for g in grid],
                 suffixes=IMAGE_SUFFIXES, what="a picture")
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
        save_image(output, image)
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
