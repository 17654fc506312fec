"""The work of one batch task, as a plain function a Dask worker runs: it reads its
inputs, does the work, writes its outputs atomically into its own folder and returns
a record (a dict of JSON values).  Errors do not escape: they become the record's
``status`` ("failed") and ``error`` (one line naming the file and what is wrong), so a
bad input costs its own task only.  Nothing here knows Dask.

A task's ``report.json`` is written last, atomically: present with a matching ``key``
and every output it lists there means the task is done (``--resume``).

>>> import os, tempfile
>>> d = tempfile.mkdtemp()
>>> rec = validate_task(os.path.join(d, "missing.wrl"))    # the validator's FBA100
>>> rec["status"], "missing.wrl" in rec["first_finding"]
('invalid', True)
"""
from __future__ import annotations

import json
import os
import time
import traceback
import warnings
from typing import Optional

from .._atomic import atomic_write, remove_stale
from .targets import Target

__all__ = ["clone_task", "validate_task", "play_task", "report_done", "one_line"]

#: The file every task folder ends with; written last.
REPORT = "report.json"
#: At most this many findings and warnings are kept in a report.
MAX_LISTED = 50


def one_line(error: BaseException) -> str:
    """An error as one line: the project's errors by their message (file, line, what),
    anything else with its type and where it was raised (a bug to report)."""
    from ..vrml.errors import LocatedError

    if isinstance(error, OSError) and error.strerror and not isinstance(error, LocatedError):
        text = f"{error.filename}: {error.strerror}" if error.filename else error.strerror
    elif isinstance(error, (LocatedError, ValueError, KeyError)) or type(error).__module__.startswith("mpeg4fba"):
        text = str(error) or type(error).__name__
    else:
        frames = traceback.extract_tb(error.__traceback__)
        at = f" (at {os.path.basename(frames[-1].filename)}:{frames[-1].lineno})" if frames else ""
        text = f"{type(error).__name__}: {error}{at}"
    return " ".join(text.split())


def report_done(folder: str, key: str) -> Optional[dict]:
    """The record in ``folder``'s report when the task there is complete with ``key``
    (status ok, every output present), else None."""
    try:
        with open(os.path.join(folder, REPORT), encoding="utf-8") as f:
            report = json.load(f)
    except (OSError, ValueError):
        return None
    if not isinstance(report, dict) or report.get("key") != key or report.get("status") != "ok":
        return None
    outputs = report.get("outputs")
    if not isinstance(outputs, list) or not all(
            isinstance(o, str) and os.path.exists(os.path.join(folder, o)) for o in outputs):
        return None
    record = report.get("record")
    return record if isinstance(record, dict) else None


def _finish(folder: str, record: dict, key: Optional[str], outputs: list, extra: dict) -> dict:
    """Write the folder's report (last, atomically) and return the record."""
    report = {"key": key, "status": record["status"], "outputs": outputs, "record": record}
    report.update(extra)
    atomic_write(os.path.join(folder, REPORT), json.dumps(report, indent=1, default=str) + "\n")
    # partial files of a worker killed while writing here (its task ran again)
    remove_stale(folder)
    return record


class _Caught:
    """The warnings raised in a block, one line each (duplicates once)."""

    def __enter__(self) -> "_Caught":
        self._cm = warnings.catch_warnings(record=True)
        self._list = self._cm.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc) -> None:
        self._cm.__exit__(*exc)

    @property
    def lines(self) -> list:
        out: list = []
        for w in self._list:
            text = " ".join(str(w.message).split())
            if text not in out:
                out.append(text)
        return out[:MAX_LISTED]


def _validation(report) -> tuple:
    """(record fields, report fields) of a validation report."""
    errors = [f for f in report.findings if f.severity == "error"]
    warns = [f for f in report.findings if f.severity == "warning"]
    ratios = {int(k): float(v) for k, v in report.ratios.items() if v is not None}
    worst = max(ratios.values(), key=lambda r: abs(r - 1), default=None)
    fields = {"errors": len(errors), "warnings": len(warns),
              "worst_fap_ratio": None if worst is None else round(worst, 6)}
    full = {"findings": [str(f) for f in report.findings[:MAX_LISTED]],
            "fap_ratios": {str(k): round(v, 6) for k, v in sorted(ratios.items())}}
    return fields, full


def clone_task(source, target: Target, settings: dict, outdir: str,
               key: Optional[str] = None) -> dict:
    """Clone ``source`` (a :class:`~mpeg4fba.cloning.PreparedSource`) onto ``target``
    into ``outdir/<name>/``: ``<name>.wrl``, ``<name>.glb`` (``settings["formats"]``),
    ``<name>.points.json`` (the points used, confidences for found ones),
    ``<name>.png`` (``settings["preview"]``) and ``report.json``.

    ``settings``: ``method``, ``snap``, ``check``, ``scale``, ``lenient``, ``formats``,
    ``preview`` (a (width, height) or None) and ``options`` (for the cloner)."""
    folder = os.path.join(outdir, target.name)
    record = {"name": target.name, "target": target.path, "points": target.points,
              "status": "failed", "error": None, "folder": folder, "warnings_raised": 0}
    extra: dict = {"times": {}, "warnings": []}
    return _in_folder(folder, record, key, extra,
                      lambda: _clone(source, target, settings, folder, record, extra))


def _in_folder(folder: str, record: dict, key: Optional[str], extra: dict, work) -> dict:
    """Run ``work()`` (it returns the names of the outputs it wrote) for a task whose
    outputs go to ``folder``: an error becomes the record's, the warnings raised go to
    the report (their count to the record's ``warnings_raised`` when it has one), the
    time to ``seconds``; then the report is written (:func:`_finish`)."""
    outputs: list = []
    t0 = time.perf_counter()
    with _Caught() as caught:
        try:
            os.makedirs(folder, exist_ok=True)
            outputs = work()
        except Exception as e:          # noqa: BLE001 - recorded, the batch goes on
            record["error"] = one_line(e)
    extra["warnings"] = caught.lines
    if "warnings_raised" in record:
        record["warnings_raised"] = len(caught.lines)
    record["seconds"] = round(time.perf_counter() - t0, 3)
    if not os.path.isdir(folder):
        return record
    return _finish(folder, record, key, outputs, extra)


def _clone(source, target: Target, settings: dict, folder: str, record: dict,
           extra: dict) -> list:
    from ..cloning.job import CloneJob
    from ..formats.face_files import read_face
    from ..formats.fpjson import write_feature_points_json

    times = extra["times"]
    t = time.perf_counter()
    face = read_face(target.path, target.points, lenient=settings.get("lenient", False))
    times["reading the target"] = time.perf_counter() - t
    job = CloneJob(source, face, method=settings.get("method", "fmc"),
                   snap=settings.get("snap", False), check=settings.get("check", True),
                   scale=settings.get("scale", True), **settings.get("options", {}))
    job.run()
    times.update(job.times)
    result = job.result
    record.update(vertices=int(sum(len(m.vertices) for m in result.meshes.values())),
                  faps=len(result.fat.faps), visemes=len(result.fat.visemes),
                  expressions=len(result.fat.expressions),
                  points_found=len(job.points.added))
    low = job.points.lowest()
    record["lowest_confidence"] = None if low is None else f"{low[0]}={low[1]:.2f}"
    t = time.perf_counter()
    outputs = []
    name = target.name
    found = job.found_points()
    points, conf = found if found else (face.points.positions_only(), None)
    write_feature_points_json(points, os.path.join(folder, name + ".points.json"), confidences=conf)
    outputs.append(name + ".points.json")
    formats = settings.get("formats", ("wrl", "glb"))
    if "wrl" in formats:
        from ..formats.wrl_face import save_face
        save_face(result, os.path.join(folder, name + ".wrl"))
        outputs.append(name + ".wrl")
    if "glb" in formats:
        from ..formats.gltf import write_glb
        write_glb(result, os.path.join(folder, name + ".glb"))
        outputs.append(name + ".glb")
    if settings.get("preview"):
        from ..render.preview import render_face, save_png
        save_png(os.path.join(folder, name + ".png"), render_face(result, size=settings["preview"]))
        outputs.append(name + ".png")
    times["writing"] = time.perf_counter() - t
    extra["times"] = {k: round(v, 3) for k, v in times.items()}
    if job.report is not None:
        fields, full = _validation(job.report)
        record.update(fields)
        extra["validation"] = full
        if fields["errors"]:
            first = next(f for f in job.report.findings if f.severity == "error")
            record["error"] = f"the cloned face does not pass validation: {first}"
            return outputs
    record["status"] = "ok"
    return outputs


def validate_task(path: str, tolerance: float = 0.05, strict: bool = False,
                  name: Optional[str] = None) -> dict:
    """Validate one face or FAP stream: status ``ok`` (no errors), ``invalid`` (read, with
    errors) or ``failed`` (not read: ``error`` says why); ``name`` is the record's name
    (default ``path``)."""
    from ..formats.validate import validate

    record = {"name": name or path, "status": "failed", "error": None,
              "kind": "stream" if path.lower().endswith(".fap") else "face"}
    t0 = time.perf_counter()
    with _Caught():
        try:
            report = validate(path, tolerance=tolerance, strict=strict)
        except Exception as e:          # noqa: BLE001 - recorded, the batch goes on
            record["error"] = one_line(e)
        else:
            fields, full = _validation(report)
            record.update(fields)
            record["findings"] = full["findings"]
            record["fap_ratios"] = full["fap_ratios"]
            errors = [f for f in report.findings if f.severity == "error"]
            record["first_finding"] = str(report.findings[0]) if report.findings else None
            record["status"] = "invalid" if errors else "ok"
    record["seconds"] = round(time.perf_counter() - t0, 3)
    return record


def play_task(face_path: str, name: str, streams: list, settings: dict, outdir: str,
              key: Optional[str] = None) -> dict:
    """Play every stream of ``streams`` ((stream name, FapStream) pairs) on one face
    into ``outdir/<name>/``: ``<stream>.glb`` (``settings["glb"]``) and PNG frames in
    ``<stream>/`` (``settings["png"]``: size, view, frame range)."""
    folder = os.path.join(outdir, name)
    record = {"name": name, "face": face_path, "stream": ";".join(s for s, _ in streams),
              "status": "failed", "error": None, "folder": folder, "outputs": 0}
    return _in_folder(folder, record, key, {"warnings": []},
                      lambda: _play(face_path, streams, settings, folder, record))


def _play(face_path: str, streams: list, settings: dict, folder: str, record: dict) -> list:
    from ..formats.face_files import read_face

    face = read_face(face_path, lenient=settings.get("lenient", False))
    if not len(face.fat):
        raise ValueError(f"{face_path}: the face has no FAT: nothing plays on it")
    record["vertices"] = int(sum(len(m.vertices) for m in face.meshes.values()))
    record["frames"] = sum(len(s) for _, s in streams)
    outputs = []
    for sname, stream in streams:
        if settings.get("glb", True):
            from ..formats.gltf import write_glb
            write_glb(face, os.path.join(folder, sname + ".glb"), stream)
            outputs.append(sname + ".glb")
        png = settings.get("png")
        if png:
            from ..render.preview import render_face, save_png
            sub = os.path.join(folder, sname)
            os.makedirs(sub, exist_ok=True)
            playback = face.play(stream)
            first, last = png.get("frames") or (0, len(stream))
            for i in range(first, min(last, len(stream))):
                rel = os.path.join(sname, f"frame_{i:04d}.png")
                save_png(os.path.join(folder, rel),
                         render_face(face, playback, frame=i, size=png["size"], view=png["view"]))
                outputs.append(rel)
    record["status"], record["outputs"] = "ok", len(outputs)
    return outputs
