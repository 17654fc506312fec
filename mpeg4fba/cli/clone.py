"""``mpeg4fba clone``: Facial Motion Cloning from the command line.

``mpeg4fba clone [SOURCE] TARGET -o OUT.wrl`` copies every FAP, viseme and expression
of SOURCE (a face with a FAT; the built-in reference head when left out) onto TARGET (a
face with feature points, from its FDP or from ``--target-points``) and writes the
target with its new FAT.  The result is checked with the validator (including the
numeric FAP check) and a summary is printed.

Example
-------
>>> import os, tempfile
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.formats.wrl_face import save_face
>>> d = tempfile.mkdtemp()
>>> save_face(reference_head(resolution=0.5, face_width=1.1, seed=2), os.path.join(d, "t.wrl"))
>>> r = CliRunner().invoke(main, ["clone", os.path.join(d, "t.wrl"), "-o", os.path.join(d, "o.wrl")])
>>> r.exit_code, r.output.splitlines()[0].startswith("cloned reference_head onto")
(0, True)
"""
from __future__ import annotations

import time
from typing import Optional

import click

from . import main, warnings_to_stderr

__all__ = ["clone_command"]


@main.command("clone", epilog="\b\nExamples:\n  mpeg4fba clone target.wrl -o animated.wrl"
                              "\n  mpeg4fba clone demy.wrl target.obj --target-points target.json -o out.wrl"
                              "\n  mpeg4fba clone source.wrl target.wrl -o out.wrl --support 0.03")
@click.argument("faces", nargs=-1, metavar="[SOURCE] TARGET")
@click.option("-o", "--output", metavar="OUT.wrl", required=True, help="The face to write (VRML).")
@click.option("--source-points", metavar="FILE", help="Feature points of SOURCE (.json sidecar or Xface .fdp).")
@click.option("--target-points", metavar="FILE", help="Feature points of TARGET (.json sidecar or Xface .fdp).")
@click.option("--support", type=click.FloatRange(min=0), default=0.02, show_default=True,
              help="Radius of the anti-aliasing filter in the alignment space (0: off).")
@click.option("--no-scale", is_flag=True, help="Copy motion as it is instead of scaling it by the faces' FAPU.")
@click.option("--positions", type=click.Choice(["global", "regional"]), default="global", show_default=True,
              help="How positions are normalised before the projection.")
@click.option("--triangulation", type=click.Choice(["fixed", "delaunay"]), default="fixed", show_default=True,
              help="Feature point triangulation used to align the faces.")
@click.option("--method", type=click.Choice(["fmc", "local-frames"]), default="fmc", show_default=True,
              help="fmc: Facial Motion Cloning (any two faces); local-frames: Kong et al.'s "
                   "local frames (faces that share a mesh).")
@click.option("--lenient", is_flag=True, help="Read VRML leniently (unknown nodes kept, with a warning).")
@click.option("--no-check", is_flag=True, help="Skip validating the result.")
def clone_command(faces: tuple, output: str, source_points: Optional[str], target_points: Optional[str],
                  support: float, no_scale: bool, positions: str, triangulation: str, method: str,
                  lenient: bool, no_check: bool) -> None:
    """Clone the facial motion of SOURCE (default: the reference head) onto TARGET."""
    from ..cloning import FacialMotionCloner
    from ..formats.face_files import read_face
    from ..formats.wrl_face import save_face

    if len(faces) not in (1, 2):
        raise click.UsageError(f"give [SOURCE] TARGET (got {len(faces)} files)")
    if len(faces) == 1 and source_points:
        raise click.UsageError("--source-points needs a SOURCE file")
    with warnings_to_stderr():
        if len(faces) == 2:
            source = read_face(faces[0], source_points, lenient=lenient)
        else:
            from ..models import reference_head
            source = reference_head()
        target = read_face(faces[-1], target_points, lenient=lenient)
        if not len(source.fat):
            raise click.ClickException(f"the source face {source.name} has no FAT: nothing to clone")
        t0 = time.perf_counter()
        if method == "local-frames":
            from ..cloning import LocalFrameCloner
            cloner = LocalFrameCloner(source, target, scale=not no_scale)
        else:
            cloner = FacialMotionCloner(source, target, support=support, scale_motion=not no_scale,
                                        positions=positions, triangulation=triangulation)
        t1 = time.perf_counter()
        result = cloner.clone()
        t2 = time.perf_counter()
        save_face(result, output)
    fat = result.fat
    click.echo(f"cloned {source.name} onto {target.name}: {len(fat.faps)} FAPs, "
               f"{len(fat.visemes)} visemes, {len(fat.expressions)} expressions "
               f"(mapping {t1 - t0:.2f} s, tables {t2 - t1:.2f} s); wrote {output}")
    if not no_check:
        from ..formats.validate import validate
        report = validate(result)
        errors = [f for f in report.findings if f.severity == "error"]
        worst = [f for f in report.findings if f.severity != "info"]
        click.echo(f"check: {len(errors)} errors, {len(worst) - len(errors)} warnings")
        for f in worst[:10]:
            click.echo(f"  {f}")
        if errors:
            raise click.ClickException("the cloned face does not pass validation")
