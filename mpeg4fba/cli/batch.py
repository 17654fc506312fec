"""``mpeg4fba batch``: clone, validate and play many faces at once on Dask.

``batch clone SOURCE TARGETS... -o OUTDIR`` (or ``--reference`` for the built-in head
as the source) writes each target's cloned face, its points, a preview and a report
into ``OUTDIR/<name>/``, and ``OUTDIR/results.csv`` and ``results.json``; ``batch
validate FILES...`` checks faces and streams; ``batch play FACES... --stream S.fap -o
OUTDIR`` plays every stream on every face.  TARGETS, FILES and FACES are files, glob
patterns (quoted) or manifest CSVs.  Without options the work runs on a local cluster
of one process worker per core; ``--workers N`` sizes it, ``--scheduler ADDRESS`` uses
an existing one.

Exit status: the number of targets that failed (at most 125; 0: all done), 1 for an
error that stops the whole batch, 2 for a usage error.

Example
-------
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> r = CliRunner().invoke(main, ["batch", "--help"])
>>> r.exit_code, "clone" in r.output
(0, True)
"""
from __future__ import annotations

import os
import sys
from typing import Optional

import click

from . import main, warnings_to_stderr
from .common import check_output_folder, show_progress
from .play import png_options

__all__ = ["batch", "exit_code"]

#: The largest exit status that counts failures (126 and up mean other things to a shell).
MAX_EXIT = 125


def exit_code(failed: int) -> int:
    """The exit status for ``failed`` failed targets.

    >>> exit_code(0), exit_code(3), exit_code(1000)
    (0, 3, 125)
    """
    return min(int(failed), MAX_EXIT)


@main.group(epilog="\b\nExamples:\n  mpeg4fba batch clone --reference 'heads/*.obj' -o out/"
                   "\n  mpeg4fba batch clone source.wrl targets.csv -o out/ --resume"
                   "\n  mpeg4fba batch validate 'library/*.wrl' 'streams/*.fap'"
                   "\n  mpeg4fba batch play 'out/*/*.wrl' --stream talk.fap -o played/"
                   "\n  mpeg4fba batch clone --reference 'heads/*.obj' -o out/ "
                   "--scheduler tcp://10.0.0.5:8786")
def batch() -> None:
    """Clone, validate and play many faces at once on Dask (a local cluster, or an
    existing one with --scheduler).

    Needs the batch extra: pip install "mpeg4fba[batch]".
    """


def _cluster_options(f):
    f = click.option("--scheduler", metavar="ADDRESS",
                     help="An existing Dask scheduler (tcp://host:8786) instead of a local cluster.")(f)
    f = click.option("--workers", type=click.IntRange(min=1), metavar="N",
                     help="Process workers of the local cluster (default: one per core).")(f)
    return f


class _Progress:
    """A bar with done / failed / remaining and an estimate on a terminal; one line per
    finished task otherwise."""

    def __init__(self, total: int, label: str):
        self.total = total
        self.done = 0
        self.bar = None
        if show_progress():
            self.bar = click.progressbar(length=total, label=label, file=sys.stderr, show_eta=True,
                                         item_show_func=self._text)
            self.bar.__enter__()
        self.counts: dict = {}

    def _text(self, record: Optional[dict]) -> str:
        c = self.counts
        bad = c.get("failed", 0) + c.get("invalid", 0)
        return f"done {self.done - bad} · failed {bad} · left {self.total - self.done}"

    def __call__(self, record: dict, counts: dict) -> None:
        self.done += 1
        self.counts = counts
        if self.bar is not None:
            self.bar.update(1, record)
            return
        line = f"[{self.done}/{self.total}] {record.get('name')}: {record.get('status')}"
        if record.get("seconds") is not None and record.get("status") != "skipped":
            line += f" ({record['seconds']:.1f} s)"
        if record.get("error"):
            line += f": {record['error']}"
        click.echo(line, err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


def _on_client(client) -> None:
    from ..batch.run import dashboard_link
    link = dashboard_link(client)
    workers = len(client.scheduler_info().get("workers", {}))
    click.echo(f"Dask: {workers} worker{'s' * (workers != 1)}"
               + (f"; dashboard {link}" if link else ""), err=True)


def _finish(results, listed: int = 20) -> None:
    click.echo(results.summary())
    for r in results.failed[:listed]:
        click.echo(f"  {r.get('name')}: {r.get('status')}: {r.get('error') or r.get('first_finding')}")
    if results.failed_count > listed:
        click.echo(f"  ... and {results.failed_count - listed} more (see the results table)")
    sys.exit(exit_code(results.failed_count))


@batch.command("clone", epilog="\b\nExamples:\n  mpeg4fba batch clone --reference 'heads/*.obj' -o out/"
                                "\n  mpeg4fba batch clone demy.wrl targets.csv -o out/ --workers 8 --resume")
@click.argument("faces", nargs=-1, required=True, metavar="SOURCE TARGETS...")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
              help="The folder for the targets' folders and results.csv / results.json.")
@click.option("--reference", is_flag=True,
              help="Clone the built-in reference head (every argument is then a target).")
@click.option("--source-points", metavar="FILE", help="Feature points of SOURCE (.json or .fdp).")
@click.option("--points-dir", metavar="DIR",
              help="Where a target without a point file in the manifest may have <stem>.json or .fdp.")
@click.option("--support", type=click.FloatRange(min=0), default=0.02, show_default=True,
              help="Radius of the anti-aliasing filter in the alignment space (0: off).")
@click.option("--no-scale", is_flag=True, help="Copy motion as it is instead of scaling it by the faces' FAPU.")
@click.option("--positions", type=click.Choice(["global", "regional"]), default="global", show_default=True)
@click.option("--triangulation", type=click.Choice(["fixed", "delaunay"]), default="fixed", show_default=True)
@click.option("--method", type=click.Choice(["fmc", "local-frames"]), default="fmc", show_default=True)
@click.option("--lenient", is_flag=True, help="Read VRML leniently (unknown nodes kept).")
@click.option("--snap", is_flag=True, help="Move the given crisp points onto each target's geometry.")
@click.option("--no-check", is_flag=True, help="Skip validating each result.")
@click.option("--formats", default="wrl,glb", show_default=True, metavar="LIST",
              help="The cloned face's files: wrl, glb or both.")
@click.option("--no-preview", is_flag=True, help="No preview PNG per target.")
@click.option("--resume", is_flag=True,
              help="Skip targets whose outputs are complete and whose inputs and options "
                   "are unchanged (by content).")
@_cluster_options
def batch_clone(faces: tuple, outdir: str, reference: bool, source_points: Optional[str],
                points_dir: Optional[str], support: float, no_scale: bool, positions: str,
                triangulation: str, method: str, lenient: bool, snap: bool, no_check: bool,
                formats: str, no_preview: bool, resume: bool, workers: Optional[int],
                scheduler: Optional[str]) -> None:
    """Clone SOURCE's facial motion onto every target, each into OUTDIR/<name>/."""
    from ..batch import clone_many
    from ..batch.targets import expand_targets

    faces = list(faces)
    source = None if reference else faces.pop(0)
    if not faces:
        raise click.UsageError("give SOURCE and at least one target (or --reference and targets)")
    if reference and source_points:
        raise click.UsageError("--source-points needs a SOURCE file")
    kinds = [k.strip().lower() for k in formats.split(",") if k.strip()]
    if not kinds or any(k not in ("wrl", "glb") for k in kinds):
        raise click.BadParameter(f"{formats!r}: expected wrl, glb or wrl,glb", param_hint="--formats")
    targets = expand_targets(faces, points_dir)
    check_output_folder(outdir, [(source, "SOURCE")] + [(t.path, "a target") for t in targets])
    options = {} if method == "local-frames" else dict(support=support, positions=positions,
                                                        triangulation=triangulation)
    progress = _Progress(len(targets), "mpeg4fba batch clone")
    try:
        with warnings_to_stderr():
            results = clone_many(source, targets, outdir, source_points=source_points,
                                 method=method, snap=snap, check=not no_check,
                                 scale=not no_scale, lenient=lenient, formats=kinds,
                                 preview=None if no_preview else (320, 384), resume=resume,
                                 workers=workers, scheduler=scheduler, progress=progress,
                                 on_client=_on_client, **options)
    finally:
        progress.close()
    click.echo(f"wrote {os.path.join(outdir, 'results.csv')} and results.json")
    _finish(results)


@batch.command("validate", epilog="\b\nExamples:\n  mpeg4fba batch validate 'library/*.wrl' 'streams/*.fap' -o report/")
@click.argument("files", nargs=-1, required=True, metavar="FILES...")
@click.option("-o", "--output", "outdir", metavar="OUTDIR", help="Write results.csv and results.json here.")
@click.option("--tolerance", default=0.05, show_default=True, type=click.FloatRange(0, 1),
              help="Relative error the numeric FAP check allows.")
@click.option("--lenient", is_flag=True, help="Read VRML leniently (keep non-VRML97 nodes).")
@_cluster_options
def batch_validate(files: tuple, outdir: Optional[str], tolerance: float, lenient: bool,
                   workers: Optional[int], scheduler: Optional[str]) -> None:
    """Check many faces and FAP streams against the MPEG-4 FBA rules."""
    from ..batch import validate_many
    from ..batch.targets import expand_targets

    paths = expand_targets(files)
    if outdir is not None:
        check_output_folder(outdir, [(t.path, "a file") for t in paths])
    progress = _Progress(len(paths), "mpeg4fba batch validate")
    try:
        results = validate_many([t.path for t in paths], tolerance=tolerance, strict=not lenient,
                                outdir=outdir, workers=workers, scheduler=scheduler,
                                progress=progress, on_client=_on_client)
    finally:
        progress.close()
    if outdir is not None:
        click.echo(f"wrote {os.path.join(outdir, 'results.csv')} and results.json")
    _finish(results)


@batch.command("play", epilog="\b\nExamples:\n  mpeg4fba batch play 'faces/*.wrl' --stream talk.fap -o played/"
                               "\n  mpeg4fba batch play 'faces/*.wrl' --stream a.fap --stream b.fap --png -o played/")
@click.argument("faces", nargs=-1, required=True, metavar="FACES...")
@click.option("--stream", "streams", multiple=True, required=True, metavar="S.fap",
              help="A FAP stream to play on every face (repeat for more).")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
              help="The folder for the faces' folders and the results table.")
@click.option("--no-glb", is_flag=True, help="No glTF animation (.glb) per face and stream.")
@click.option("--png", is_flag=True, help="PNG frames per face and stream, in <stream>/.")
@png_options
@click.option("--lenient", is_flag=True, help="Read VRML leniently (keep non-VRML97 nodes).")
@click.option("--resume", is_flag=True, help="Skip faces whose outputs are complete and unchanged.")
@_cluster_options
def batch_play(faces: tuple, streams: tuple, outdir: str, no_glb: bool, png: bool,
               frames: Optional[str], size: str, view: str, lenient: bool, resume: bool,
               workers: Optional[int], scheduler: Optional[str]) -> None:
    """Play every FAP stream on every face: glTF animations and/or PNG frames."""
    from ..batch import play_many
    from ..batch.targets import expand_targets
    from .play import parse_size

    if no_glb and not png:
        raise click.UsageError("nothing to write: --no-glb without --png")
    targets = expand_targets(faces)
    check_output_folder(outdir, [(t.path, "a face") for t in targets] + [(s, "--stream") for s in streams])
    span = None
    if frames is not None:
        try:
            a, _, b = frames.partition(":")
            span = (int(a) if a else 0, int(b) if b else 1 << 62)
        except ValueError:
            raise click.BadParameter(f"{frames!r}: expected FIRST:LAST frame numbers, e.g. 0:50",
                                     param_hint="--frames") from None
        if not 0 <= span[0] < span[1]:
            raise click.BadParameter(f"{frames!r}: FIRST must be at least 0 and below LAST",
                                     param_hint="--frames")
    spec = {"size": parse_size(size), "view": view, "frames": span} if png else None
    progress = _Progress(len(targets), "mpeg4fba batch play")
    try:
        with warnings_to_stderr():
            results = play_many(targets, list(streams), outdir, glb=not no_glb, png=spec,
                                lenient=lenient, resume=resume, workers=workers,
                                scheduler=scheduler, progress=progress, on_client=_on_client)
    finally:
        progress.close()
    click.echo(f"wrote {os.path.join(outdir, 'results.csv')} and results.json")
    _finish(results)
