"""``mpeg4fba clone``: Facial Motion Cloning from the command line.

``mpeg4fba clone [SOURCE] TARGET -o OUT.wrl`` copies every FAP, viseme and expression
of SOURCE (a face with a FAT; the built-in reference head when left out) onto TARGET (a
face with feature points, from its FDP or from ``--target-points``) and writes the
target with its new FAT.  The result is checked with the validator (including the
numeric FAP check) and a summary is printed.  The output is checked before any work
(not an input, a VRML or glTF name, its folder there and writable); on a terminal a
progress bar names the steps; the cloner's warnings come one line per kind, with a count.

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

from typing import Optional, Sequence

import click

from . import main, warnings_to_stderr
from .common import check_output, run_steps

__all__ = ["clone_command", "found_points_path"]


def check_lines(findings: Sequence, output: str, shown: int = 10) -> list:
    """The lines ``clone`` prints for its check of the result: the counts, the first
    ``shown`` errors and warnings, and how many more there are.

    >>> from mpeg4fba.fba.compliance import Finding
    >>> check_lines([Finding("FBA014", f"FAP {n}: off") for n in (3, 4, 5)], "out.wrl", shown=2)[-1]
    '  ... and 1 more (all of them: mpeg4fba validate out.wrl)'
    """
    errors = [f for f in findings if f.severity == "error"]
    worst = [f for f in findings if f.severity != "info"]
    lines = [f"check: {len(errors)} errors, {len(worst) - len(errors)} warnings"]
    lines += [f"  {f}" for f in worst[:shown]]
    if len(worst) > shown:
        lines.append(f"  ... and {len(worst) - shown} more (all of them: mpeg4fba validate {output})")
    return lines


def found_points_path(output: str) -> str:
    """Where ``clone`` writes the points it found on the target: beside the output.

    >>> found_points_path("out/head_animated.wrl.gz")
    'out/head_animated.points.json'
    """
    stem = output
    for suffix in (".gz", ".wrz", ".wrl", ".glb", ".gltf"):
        if stem.lower().endswith(suffix):
            stem = stem[: -len(suffix)]
    return stem + ".points.json"


def _say_points(report, target: str, where: str) -> None:
    """One line per thing done to the target's points (none when they were all given)."""
    import os

    if report.snapped:
        k, d = max(report.snapped.items(), key=lambda kv: kv[1])
        click.echo(f"snapped {len(report.snapped)} points onto the target's geometry "
                   f"(farthest {k}, moved {d:.3g} model units)")
    if report.added:
        worst, conf = report.lowest()
        name = os.path.basename(target)
        how = (f"no feature points given: found {len(report.added)}" if not report.kept else
               f"{len(report.kept)} feature points given: found the {len(report.added)} missing")
        same = "; put in the source's convention" if not report.kept else ""
        click.echo(f"{name}: {how} on its geometry (lowest confidence {conf:.2f}: {worst}{same}); "
                   f"wrote them to {where} (review: mpeg4fba points {target} --points {where} --edit)")
    for note in (report.found.notes if report.found is not None else ()):
        click.echo(f"{os.path.basename(target)}: note: {note}")


@main.command("clone", epilog="\b\nExamples:\n  mpeg4fba clone target.wrl -o animated.wrl"
                              "\n  mpeg4fba clone demy.wrl target.obj --target-points target.json -o out.wrl"
                              "\n  mpeg4fba clone source.wrl target.wrl -o out.wrl --support 0.03")
@click.argument("faces", nargs=-1, metavar="[SOURCE] TARGET")
@click.option("-o", "--output", metavar="OUT.wrl", required=True,
              help="The face to write: VRML (.wrl, .wrz, .wrl.gz) or glTF (.glb, .gltf).")
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
@click.option("--snap", is_flag=True,
              help="Move the crisp points of --target-points (lip and eye corners, mid-lip, nose "
                   "tip, chin, ...) onto the target's geometry before cloning, and the inner "
                   "lips' points across the mouth's slit onto their lip's edge, as the "
                   "source's lie.")
@click.option("--no-check", is_flag=True, help="Skip validating the result.")
def clone_command(faces: tuple, output: str, source_points: Optional[str], target_points: Optional[str],
                  support: float, no_scale: bool, positions: str, triangulation: str, method: str,
                  lenient: bool, snap: bool, no_check: bool) -> None:
    """Clone the facial motion of SOURCE (default: the reference head) onto TARGET."""
    from ..formats.face_files import VRML_SUFFIXES

    if len(faces) not in (1, 2):
        raise click.UsageError(f"give [SOURCE] TARGET (got {len(faces)} files)")
    if len(faces) == 1 and source_points:
        raise click.UsageError("--source-points needs a SOURCE file")
    if snap and not target_points:
        raise click.UsageError("--snap moves the points of --target-points: give that file")
    # before the 10-20 seconds of work: a bad output is found now, not at the end
    check_output(output, [(faces[0], "SOURCE") if len(faces) == 2 else None,
                          (faces[-1], "TARGET"), (source_points, "--source-points"),
                          (target_points, "--target-points")],
                 suffixes=VRML_SUFFIXES + (".glb", ".gltf"), what="a face")
    points_out = found_points_path(output)
    check_output(points_out, [(f, "a face") for f in faces] + [(output, "-o")],
                 suffixes=(".json",), what="the found points")
    times: dict = {}

    from ..cloning.job import CloneJob
    # the faces are given to the job when read (its first step here)
    job = CloneJob(None, None, method=method, snap=snap, check=not no_check,
                   scale=not no_scale,
                   **({} if method == "local-frames" else
                      dict(support=support, positions=positions, triangulation=triangulation)))

    def read() -> None:
        from ..formats.face_files import read_face
        if len(faces) == 2:
            job.source = read_face(faces[0], source_points, lenient=lenient)
        else:
            from ..models import reference_head
            job.source = reference_head()
        job.target = read_face(faces[-1], target_points, lenient=lenient)
        if not len(job.source.fat):
            raise click.ClickException(f"the source face {job.source.name} has no FAT: "
                                       "nothing to clone")

    def write() -> None:
        from ..formats.wrl_face import save_face
        found = job.found_points()
        if found:
            from ..formats.fpjson import write_feature_points_json
            write_feature_points_json(found[0], points_out, confidences=found[1])
        save_face(job.result, output)

    with warnings_to_stderr():
        run_steps([("reading the faces", read)] + job.steps() + [("writing", write)],
                  "mpeg4fba clone", times)
    source, target, result = job.source, job.target, job.result
    _say_points(job.points, faces[-1], points_out)
    fat = result.fat
    click.echo(f"cloned {source.name} onto {target.name}: {len(fat.faps)} FAPs, "
               f"{len(fat.visemes)} visemes, {len(fat.expressions)} expressions "
               f"(mapping {times['mapping the faces']:.2f} s, tables {times['cloning the tables']:.2f} s); wrote {output}")
    if not no_check:
        for line in check_lines(job.report.findings, output):
            click.echo(line)
        if any(f.severity == "error" for f in job.report.findings):
            raise click.ClickException("the cloned face does not pass validation")
