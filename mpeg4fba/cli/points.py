"""``mpeg4fba points``: find the feature points on a head, and review them.

* ``mpeg4fba points HEAD -o HEAD.json``: finds the MPEG-4 feature points on the head's
  geometry (:func:`mpeg4fba.cloning.find_feature_points`) and writes them, each with its
  confidence, in the JSON sidecar format, with a picture of them (``HEAD.png`` beside
  the JSON; ``--preview`` names it, ``--no-preview`` skips it);
* ``--edit`` / ``-o review.html``: a page to review and move the points in a browser,
  and save the sidecar JSON from there (works from ``file://``);
* ``--points FILE``: start from a point file instead of finding them (to review it, or,
  with ``--snap``, to move its crisp points onto the geometry).

Example
-------
>>> import os, tempfile
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> from mpeg4fba.models import reference_head
>>> from mpeg4fba.formats.wrl_face import save_face
>>> d = tempfile.mkdtemp()
>>> save_face(reference_head(resolution=0.5), os.path.join(d, "head.wrl"))
>>> r = CliRunner().invoke(main, ["points", os.path.join(d, "head.wrl"), "--no-preview"])
>>> r.exit_code, r.output.startswith("found "), os.path.exists(os.path.join(d, "head.json"))
(0, True, True)
"""
from __future__ import annotations

import os
import time
from typing import Optional

import click

from . import main, warnings_to_stderr
from .common import check_output

__all__ = ["points_command", "describe_found", "frame_of_points"]


def _ids(ids) -> str:
    ids = list(ids)
    return ", ".join(ids[:12]) + (f" and {len(ids) - 12} more" if len(ids) > 12 else "")


def describe_found(found, what: str, seconds: Optional[float] = None) -> str:
    """One line on a :class:`~mpeg4fba.cloning.detect.FoundPoints`: how many, the least
    confident, what the head has no geometry for."""
    worst, conf = found.lowest()
    took = f" in {seconds:.1f} s" if seconds is not None else ""
    text = (f"found {len(found.points)} feature points on {what}{took} "
            f"(lowest confidence {conf:.2f}: {worst})")
    if found.missing:
        why = sorted({found.reasons.get(k, "") for k in found.missing} - {""})
        text += f"; not on this head: {_ids(found.missing)}" + (f" ({'; '.join(why)})" if why else "")
    for note in found.notes:
        text += f"; note: {note}"
    return text


def _default_output(head: str, edit: bool) -> str:
    stem, _ = os.path.splitext(head)
    if stem.lower().endswith((".wrl", ".gltf")):  # head.wrl.gz
        stem = os.path.splitext(stem)[0]
    return stem + (".points.html" if edit else ".json")


@main.command("points", epilog="\b\nExamples:\n  mpeg4fba points head.obj -o head.json"
                               "\n  mpeg4fba points head.obj --edit -o review.html"
                               "\n  mpeg4fba points head.obj --points head.json --snap -o snapped.json")
@click.argument("head", metavar="HEAD")
@click.option("-o", "--output", metavar="OUT.json|OUT.html",
              help="The sidecar to write (.json), or with --edit the review page (.html). "
                   "Default: HEAD's name with .json (.points.html with --edit).")
@click.option("--edit", is_flag=True, help="Write a page to review and move the points in a browser.")
@click.option("--points", "given", metavar="FILE",
              help="Start from these points (.json or Xface .fdp) instead of finding them.")
@click.option("--snap", is_flag=True, help="With --points: move the crisp points (lip and eye corners, "
                                           "mid-lip, nose tip, chin, ...) onto the geometry, and the "
                                           "inner lips' points across the slit onto their lip's edge.")
@click.option("--preview", metavar="PNG", help="Where to draw the points (default: beside the JSON).")
@click.option("--no-preview", is_flag=True, help="Draw no picture.")
@click.option("--lenient", is_flag=True, help="Read VRML leniently (unknown nodes kept, with a warning).")
def points_command(head: str, output: Optional[str], edit: bool, given: Optional[str], snap: bool,
                   preview: Optional[str], no_preview: bool, lenient: bool) -> None:
    """Find the MPEG-4 feature points on HEAD (.obj, .glb, .gltf, .wrl, .ply, .stl, .off) and write them."""
    if snap and not given:
        raise click.UsageError("--snap moves the points of a file: give it with --points")
    if preview and no_preview:
        raise click.UsageError("give --preview or --no-preview, not both")
    output = output or _default_output(head, edit)
    if output.lower().endswith((".html", ".htm")):
        edit = True
    elif edit:
        raise click.UsageError(f"--edit writes a page: give -o NAME.html (not {output})")
    inputs = [(head, "HEAD"), (given, "--points")]
    check_output(output, inputs, suffixes=(".html", ".htm") if edit else (".json",),
                 what="a review page" if edit else "a feature point sidecar")
    if not edit and not no_preview:
        preview = preview or os.path.splitext(output)[0] + ".png"
        check_output(preview, inputs + [(output, "-o")], suffixes=(".png",), what="a picture")
    with warnings_to_stderr():
        _points(head, output, edit, given, snap, None if edit or no_preview else preview, lenient)


def _points(head: str, output: str, edit: bool, given: Optional[str], snap: bool,
            preview: Optional[str], lenient: bool) -> None:
    from ..cloning.alignment import REQUIRED_POINTS
    from ..cloning.detect import find_feature_points
    from ..cloning.snapping import snap_points
    from ..fba.requirements import required_points
    from ..formats.face_files import read_face

    face = read_face(head, given, lenient=lenient)
    what = os.path.basename(head)
    confidence: dict = {}
    up = forward = None
    missing: tuple = ()
    reasons: dict = {}
    if given:
        points = face.points
        if given.lower().endswith(".json"):
            from ..formats.fpjson import read_confidences
            confidence = {k: c for k, c in read_confidences(given).items() if k in points}
        up, forward = frame_of_points(points)
        if snap:
            points, moved = snap_points(face, points)
            far = max(moved.items(), key=lambda kv: kv[1], default=None)
            click.echo(f"snapped {len(moved)} points of {os.path.basename(given)} onto the "
                       f"geometry" + (f" (farthest {far[0]}, moved {far[1]:.3g} model units)" if far else ""))
        wanted = required_points(base=REQUIRED_POINTS)
        missing = tuple(points.missing(wanted))
        reasons = {k: "not in the point file" for k in missing}
        notes: tuple = ()
    else:
        t0 = time.perf_counter()
        found = find_feature_points(face)
        click.echo(describe_found(found, what, time.perf_counter() - t0))
        points, confidence, missing, reasons = found.points, found.confidence, found.missing, found.reasons
        notes = found.notes
        up, forward = found.up, found.forward
    # positions are exact; a vertex ref only names the nearest vertex (a reader would
    # move the point onto it), so the sidecar keeps positions only
    plain = points.positions_only()
    written = [output]
    if edit:
        from ..render.point_editor import write_point_editor
        write_point_editor(output, face, plain, confidences=confidence or None, missing=missing,
                           reasons=reasons, title=f"feature points of {what}", up=up, forward=forward,
                           notes=notes)
    else:
        from ..formats.fpjson import write_feature_points_json
        write_feature_points_json(plain, output, confidences=confidence or None)
        if preview:
            from ..render.points import render_points, upright
            shown, shown_points = upright(face, plain, up, forward)
            render_points(shown, shown_points, preview, confidences=confidence or None)
            written.append(preview)
    click.echo(f"wrote {', '.join(written)}")


def frame_of_points(points) -> tuple:
    """(up, forward) of a head from its points (the face's left from the right pupil to the
    left one, up from the mouth to the eyes, forward their cross product), or (None,
    None) without the pupils or a point of the mouth.  Good for a view, not a measure:
    the mouth stands forward of the eyes, so up leans back about 10 degrees.

    >>> from mpeg4fba.fba.featurepoints import FeaturePointSet
    >>> up, fwd = frame_of_points(FeaturePointSet({"3.5": (0, 3, 1), "3.6": (0, 3, -1), "8.1": (0, 0, 0)}))
    >>> up.tolist(), fwd.tolist()      # its left is +z: it faces -x
    ([0.0, 1.0, 0.0], [-1.0, 0.0, 0.0])
    """
    import numpy as np

    mouth = [points[k] for k in ("2.2", "2.3", "8.1", "8.2", "8.3", "8.4") if k in points]
    if "3.5" not in points or "3.6" not in points or not mouth:
        return None, None
    left = points["3.5"] - points["3.6"]
    up = (points["3.5"] + points["3.6"]) / 2 - np.mean(mouth, axis=0)
    n = np.linalg.norm(left)
    if n == 0:
        return None, None
    left = left / n
    up = up - np.dot(up, left) * left
    if np.linalg.norm(up) < 1e-12:
        return None, None
    up = up / np.linalg.norm(up)
    return up, np.cross(left, up)
