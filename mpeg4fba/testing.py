"""Assertions for tests of FAP playback: is a face's FAT true to the FAPU, and does
playback still give what it gave (golden files)?

* :func:`assert_fap_compliant` plays a stream and checks, frame by frame, that each
  animated low-level FAP moves its feature point along the FAP's axis by value x FAPU
  (translations), or turns its Transform by value x 1e-5 rad (rotations), counting only
  that FAP's own contribution.
* :func:`assert_playback_matches` compares a playback (every mesh's vertices, every
  Transform's rotation, translation and scale) with a golden ``.npz`` file, or writes
  it with ``update=True`` or ``MPEG4FBA_UPDATE_GOLDEN=1``.

Both raise ``AssertionError`` with a message that names what is wrong (FAP, frame,
mesh, vertex, expected and actual values), so they read well in pytest and unittest.
With pytest, the plugin :mod:`mpeg4fba.pytest_plugin` (loaded automatically once the
package is installed) offers them as the fixtures ``fap_compliance`` and
``playback_golden``; see ``docs/testing.md``.

An example test::

    from mpeg4fba import FapStream, load_face
    from mpeg4fba.testing import assert_fap_compliant, assert_playback_matches

    def test_my_face(tmp_path):
        face = load_face("my_face.wrl")
        stream = FapStream.from_values({"open_jaw": [0, 400, 800], "head_yaw": [0, 1e4, 2e4]})
        report = assert_fap_compliant(face, stream, tolerance=0.05)
        assert 3 in report.checked
        assert_playback_matches(face, stream, "golden/my_face.npz")

    # or, with the pytest plugin's fixtures:
    def test_my_face_with_fixtures(fap_compliance, playback_golden):
        face = load_face("my_face.wrl")
        stream = FapStream.from_values({"open_jaw": [0, 400, 800]})
        fap_compliance(face, stream)
        playback_golden(face, stream)     # tests/golden/test_my_face_with_fixtures.npz

A face whose FAT opens the jaw by exactly MNS per unit passes; one 10% too wide fails:

>>> from mpeg4fba.fba import FAPU, FapStream, FeaturePointSet
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
>>> fapu = FAPU(IRISD0=1.0, ES0=6.0, ENS0=3.5, MNS0=1.5, MW0=5.0)
>>> def face(scale=1.0):
...     jaw = FaceDefMesh("Skin", [0, 4320], [0, 1], [[0, -scale * fapu.MNS, 0], [0, -fapu.MNS / 2, 0]])
...     skin = FaceMesh("Skin", [[0, -3, 1], [1, -3, 1], [0, -2, 1]], [[0, 1, 2]])
...     return FaceModel([skin], points=FeaturePointSet({"2.1": (0, -3, 1)}), fapu=fapu,
...                      fat=FAT([FaceDefTable(3, [jaw])]))
>>> stream = FapStream.from_values({"open_jaw": [0, 300, 1000], "raise_b_midlip": [0, 5, 9]})
>>> assert_fap_compliant(face(), stream)
<ComplianceReport: checked 3 open_jaw; skipped 5 raise_b_midlip (no table in the FAT)>
>>> assert_fap_compliant(face(1.1), stream)
Traceback (most recent call last):
...
AssertionError: 1 FAP of 1 checked is not compliant (tolerance 5%):
  FAP 3 open_jaw: feature point 2.1 (Skin vertex 0): frame 1 moved [0, -0.4834, 0], expected [0, -0.4395, 0] (error 10.0%; 2 of 3 frames off)
skipped: 5 raise_b_midlip (no table in the FAT)
"""
from __future__ import annotations

from ._atomic import atomic_write

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Optional, Union

import numpy as np
from scipy.spatial import cKDTree

from .fba.face import FaceModel, table_values
from .fba.fapu import AU
from .fba.fat import interval_weights, rotation_matrices
from .fba.stream import FapStream
from .fba.tables import FAP, N_FAPS

__all__ = ["assert_fap_compliant", "assert_playback_matches", "ComplianceReport",
           "playback_arrays", "UPDATE_ENV"]

#: Environment variable that makes :func:`assert_playback_matches` write golden files.
UPDATE_ENV = "MPEG4FBA_UPDATE_GOLDEN"
_SHOWN = 10          # offenders listed in a message


@dataclass
class ComplianceReport:
    """What :func:`assert_fap_compliant` looked at: FAP numbers ``checked``, FAPs
    ``skipped`` (number -> why), and the largest relative error of each checked FAP."""

    checked: list = field(default_factory=list)
    skipped: dict = field(default_factory=dict)
    worst: dict = field(default_factory=dict)

    def summary(self) -> str:
        checked = ", ".join(f"{n} {FAP[n].name}" for n in self.checked) or "none"
        skipped = ", ".join(f"{n} {FAP[n].name} ({why})" for n, why in self.skipped.items())
        return f"checked {checked}; skipped {skipped or 'none'}"

    def __repr__(self) -> str:
        return f"<ComplianceReport: {self.summary()}>"


@dataclass
class _Offence:
    error: float
    fap: int
    frame: int
    what: str
    expected: object
    actual: object
    frames_off: int
    frames: int

    def line(self) -> str:
        return (f"  FAP {self.fap} {FAP[self.fap].name}: {self.what}: frame {self.frame} "
                f"{_fmt(self.actual)}, expected {_fmt(self.expected)} (error "
                f"{self.error:.1%}; {self.frames_off} of {self.frames} frames off)")


def _fmt(v) -> str:
    if isinstance(v, str):
        return v
    if np.ndim(v) == 0:
        return f"{float(v):.4g}"
    return "[" + ", ".join(f"{x:.4g}" if x != 0 else "0" for x in np.asarray(v, float) + 0.0) + "]"


def _numbers(faps: Optional[Iterable]) -> Optional[list]:
    if faps is None:
        return None
    if isinstance(faps, (int, str)):
        faps = [faps]
    return sorted({FAP.number(f) for f in faps})


def _descendants(face: FaceModel, transforms: set) -> list:
    """Meshes hanging (at any depth) under one of ``transforms``."""
    return [name for name, m in face.meshes.items()
            if m.parent is not None and transforms & set(face.chain(m.parent))]


def _single_fap_playback(face: FaceModel, fap: int, values: np.ndarray, fps: float):
    """A playback of the stream's values of ``fap`` alone (every other FAP at 0)."""
    v = np.zeros((len(values), N_FAPS))
    v[:, fap - 1] = values
    mask = np.zeros_like(v, dtype=bool)
    mask[:, fap - 1] = True
    return face.play(FapStream(v, mask, fps))


def _nearest(face: FaceModel, wanted: dict) -> dict:
    """{feature point: {mesh: (distance, vertex)}} for the meshes each point asks for,
    one KD-tree query per mesh for all its points (neutral world positions)."""
    by_mesh: dict = {}
    for fp, meshes in wanted.items():
        for m in meshes:
            by_mesh.setdefault(m, []).append(fp)
    out: dict = {fp: {} for fp in wanted}
    for mesh, fps in by_mesh.items():
        verts = face.world_vertices(mesh)
        if not len(verts):
            continue
        dist, idx = cKDTree(verts).query(np.array([face.points[fp] for fp in fps]))
        for fp, d, i in zip(fps, dist, idx):
            out[fp][mesh] = (float(d), int(i))
    return out


def assert_fap_compliant(face: FaceModel, stream: FapStream, *, tolerance: float = 0.05,
                         faps: Optional[Iterable] = None) -> ComplianceReport:
    """Check that ``face`` plays ``stream`` as the FAPs' definitions say.

    For every low-level FAP the stream animates (or only ``faps``, by number or name)
    and the face's FAT has a table for, frame by frame, with every other FAP at 0:

    * translations (``FAP[n].motion == "translation"``): the feature point
      ``FAP[n].feature_point`` -- the vertex tied to it in ``face.points``, else the
      vertex nearest its neutral position among the meshes the FAP's table deforms (or
      hangs under a Transform it drives; all meshes when neither) -- must move by
      ``value x face.fapu.unit(n)`` along ``FAP[n].axis``, in the face frame (the
      mesh's transform chain, as the FAP drives it, applied);
    * rotations: each Transform the table rotates must turn by ``value x 1e-5`` rad
      about ``FAP[n].axis`` (the signed angle of the FAP's rotation about that axis).

    The error of a frame is ``|actual - expected|`` over ``max(|expected|, one FAP
    unit)``: a relative error that also counts motion off the axis, and holds a FAP at
    0 to within ``tolerance`` units.  FAPs without a table are skipped, and so are the
    scale and curl FAPs (pupils, tongue roll), translations whose feature point has no
    position, and rotations whose table drives no Transform rotation: the returned
    :class:`ComplianceReport` says which were checked and which skipped, and why.

    Raises AssertionError listing the worst offenders (FAP number and name, frame,
    expected vs actual), or when nothing could be checked.
    """
    held, given, vis, exp = stream.held()
    requested = _numbers(faps)
    candidates = requested if requested is not None else [n for n in stream.animated if n > 2]
    animated = set(stream.animated)
    report = ComplianceReport()
    jobs = []                                  # (fap, table, values)
    for n in candidates:
        record = FAP[n]
        if n <= 2:
            report.skipped[n] = "high-level FAP: not checked"
        elif n not in animated:
            report.skipped[n] = "not in the stream"
        elif n not in face.fat:
            report.skipped[n] = "no table in the FAT"
        elif record.motion not in ("translation", "rotation"):
            report.skipped[n] = f"{record.motion} FAP: not checked"
        else:
            table = face.fat[n]
            jobs.append((n, table, table_values(table, held, given, vis, exp)))
    # Where each translational FAP's feature point is: tied vertex, else the nearest.
    wanted, tied = {}, {}
    for n, table, _ in jobs:
        record = FAP[n]
        if record.motion != "translation":
            continue
        fp = record.feature_point
        if fp not in face.points:
            report.skipped[n] = f"feature point {fp} has no position in face.points"
            continue
        vertex = face.points.vertex(fp)
        if vertex is not None and (vertex[0] in face.meshes or
                                   (vertex[0] is None and len(face.meshes) == 1)):
            tied[fp] = (vertex[0] or next(iter(face.meshes)), vertex[1])
            continue
        meshes = {m.mesh for m in table.meshes} or set(_descendants(
            face, {t.transform for t in table.transforms}))
        wanted.setdefault(fp, set()).update(meshes or face.meshes)
    compiled = face.compile()                  # reports a FAT that does not fit the face
    nearest = _nearest(face, wanted)
    fapu = face.fapu
    offences = []
    for n, table, values in jobs:
        if n in report.skipped:
            continue
        record = FAP[n]
        single = _single_fap_playback(face, n, values, stream.fps)
        if record.motion == "translation":
            if fapu is None:
                raise AssertionError(f"FAP {n} {record.name} can't be checked: the face has no "
                                     "FAPU (give it fapu= or the feature points it is measured "
                                     "between)")
            fp = record.feature_point
            if fp in tied:
                mesh, v = tied[fp]
            else:
                mesh = min(nearest[fp], key=lambda m: nearest[fp][m][0])
                v = nearest[fp][mesh][1]
            unit = fapu.unit(n)
            expected = values[:, None] * unit * np.asarray(record.axis)
            actual = _moved(face, compiled, single, table, mesh, v, values)
            err = np.linalg.norm(actual - expected, axis=1) / np.maximum(
                np.linalg.norm(expected, axis=1), abs(unit))
            what = f"feature point {fp} ({mesh} vertex {v})"
            offences += _offences(n, err, tolerance, what, expected, actual, report,
                                  lambda e, a: f"moved {_fmt(a)}")
        else:
            names = [t.transform for t in table.transforms if t.field == "rotation"]
            if not names:
                report.skipped[n] = "its table rotates no Transform"
                continue
            expected = values * AU
            for name in dict.fromkeys(names):
                tr = face.transforms[name]
                R0 = rotation_matrices(tr.rotation[:3], [tr.rotation[3]])[0]
                R = single.transform(name)["rotation"] @ R0.T       # the FAP's own turn
                angle = _signed_angle(R, np.asarray(record.axis, float))
                miss = np.angle(np.exp(1j * (angle - expected)))     # wrapped to +-pi
                err = np.abs(miss) / np.maximum(np.abs(expected), AU)
                offences += _offences(n, err, tolerance, f"Transform {name}", expected,
                                      angle, report, lambda e, a: f"turned {a:.5g} rad")
        if n not in report.skipped:
            report.checked.append(n)
    report.checked.sort()
    report.skipped = dict(sorted(report.skipped.items()))
    if offences:
        offences.sort(key=lambda o: -o.error)
        bad = len({o.fap for o in offences})
        lines = [f"{bad} FAP{'s' if bad > 1 else ''} of {len(report.checked)} checked "
                 f"{'are' if bad > 1 else 'is'} not compliant (tolerance {tolerance:.0%}):"]
        lines += [o.line() for o in offences[:_SHOWN]]
        if len(offences) > _SHOWN:
            lines.append(f"  ... and {len(offences) - _SHOWN} more")
        if report.skipped:
            lines.append("skipped: " + ", ".join(f"{k} {FAP[k].name} ({why})"
                                                 for k, why in report.skipped.items()))
        raise AssertionError("\n".join(lines))
    if not report.checked:
        raise AssertionError("no FAP could be checked: " + report.summary())
    return report


def _offences(n: int, err: np.ndarray, tolerance: float, what: str, expected, actual,
              report: ComplianceReport, describe) -> list:
    """The worst frame of one FAP (and target) if any frame is off, as an _Offence."""
    if not len(err):
        return []
    err = np.where(np.isfinite(err), err, np.inf)
    worst = int(np.argmax(err))
    report.worst[n] = max(report.worst.get(n, 0.0), float(err[worst]))
    off = int((err > tolerance).sum())
    if not off:
        return []
    e, a = expected[worst], actual[worst]
    exp_text = f"{e:.5g} rad" if np.ndim(e) == 0 else _fmt(e)
    return [_Offence(float(err[worst]), n, worst, what, exp_text, describe(e, a), off, len(err))]


def _moved(face: FaceModel, compiled, single, table, mesh: str, v: int,
           values: np.ndarray) -> np.ndarray:
    """World displacement [frames, 3] of vertex ``v`` of ``mesh`` by one FAP's table:
    its rows of the compiled operator times the table's interval weights, then the
    mesh's transform chain as that FAP alone drives it."""
    op = compiled.meshes[mesh]
    local = np.zeros((len(values), 3))
    rows = op.BT[3 * v:3 * v + 3].toarray()                  # [3, slots]
    for t, m, first in op.entries:
        if t is table:
            local += interval_weights(m.borders, values) @ rows[:, first:first + m.n_intervals].T
    parent = face.meshes[mesh].parent
    p0 = face.meshes[mesh].vertices[v]
    M0 = face.world_matrix(parent)[0]
    chain = face.chain(parent)
    M = face.world_matrix(parent, {name: single.local_matrices(name) for name in chain})
    M = np.broadcast_to(M, (len(values), 4, 4))
    moved = np.einsum("fij,fj->fi", M[:, :3, :3], p0 + local) + M[:, :3, 3]
    return moved - (M0[:3, :3] @ p0 + M0[:3, 3])


def _signed_angle(R: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Signed angle [frames] of rotations R [frames, 3, 3] about a unit ``axis``."""
    axis = axis / np.linalg.norm(axis)
    s = 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0],
                        R[:, 1, 0] - R[:, 0, 1]], axis=1)
    c = 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0)
    return np.arctan2(s @ axis, c)


# -- golden files ----------------------------------------------------------------------------
def playback_arrays(face: FaceModel, stream: FapStream) -> dict:
    """Everything a playback computes, by golden-file key: ``mesh/<name>`` -> vertices
    [frames, n, 3], ``transform/<name>/<rotation|translation|scale>``."""
    p = face.play(stream)
    out = {f"mesh/{m}": p.vertices(m) for m in face.meshes}
    for t in face.transforms:
        for k, a in p.transform(t).items():
            out[f"transform/{t}/{k}"] = a
    return out


def _describe(key: str) -> str:
    kind, _, rest = key.partition("/")
    if kind == "mesh":
        return f"mesh {rest!r}"
    name, _, what = rest.rpartition("/")
    return f"transform {name!r} {what}" if kind == "transform" else key


def _where(key: str, index: tuple) -> str:
    if key.startswith("mesh/") and len(index) == 3:
        return f"frame {index[0]}, vertex {index[1]} ({'xyz'[index[2]]})"
    if len(index) == 3:
        return f"frame {index[0]}, element [{index[1]}, {index[2]}]"
    if len(index) == 2:
        return f"frame {index[0]}, component {'xyz'[index[1]] if index[1] < 3 else index[1]}"
    return f"index {index}"


def _updating(update: bool) -> bool:
    return bool(update) or os.environ.get(UPDATE_ENV, "").strip().lower() not in ("", "0", "false", "no")


def _write_atomically(path: Path, arrays: dict) -> None:
    import io
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    atomic_write(path, buffer.getvalue())


def assert_playback_matches(face: FaceModel, stream: FapStream, golden_path: Union[str, Path], *,
                            atol: float = 1e-6, update: bool = False) -> None:
    """Compare ``face.play(stream)`` (all meshes' vertices, all transforms) with the golden
    file ``golden_path`` (.npz), to within ``atol``.

    With ``update=True``, or the environment variable ``MPEG4FBA_UPDATE_GOLDEN=1``, the
    file is written instead (atomically: a temporary file in the same folder, then a
    rename; left untouched when it already holds exactly these arrays).  A mismatch
    raises AssertionError naming each mesh / transform that differs, the frame and
    vertex of its largest difference, and that difference.
    """
    path = Path(golden_path)
    now = playback_arrays(face, stream)
    if _updating(update):
        if path.is_file():
            with np.load(path) as old:
                same = set(old.files) == set(now) and all(
                    old[k].shape == a.shape and np.array_equal(old[k], a) for k, a in now.items())
            if same:
                return
        _write_atomically(path, now)
        return
    if not path.is_file():
        raise AssertionError(f"golden file {path} does not exist: write it with update=True, "
                             f"pytest --update-golden or {UPDATE_ENV}=1")
    with np.load(path) as z:
        golden = {k: z[k] for k in z.files}
    problems = []
    for key in sorted(set(golden) - set(now)):
        problems.append(f"{_describe(key)} is in the golden file but not in the playback")
    for key in sorted(set(now) - set(golden)):
        problems.append(f"{_describe(key)} is in the playback but not in the golden file")
    for key in sorted(set(now) & set(golden)):
        a, g = now[key], golden[key]
        if a.shape != g.shape:
            problems.append(f"{_describe(key)}: shape {a.shape}, golden {g.shape}")
            continue
        diff = np.abs(a - g)
        diff = np.where(np.isnan(a) & np.isnan(g), 0.0, np.where(np.isnan(diff), np.inf, diff))
        if not diff.size or not (diff > atol).any():
            continue
        index = np.unravel_index(int(np.argmax(diff)), diff.shape)
        off = diff > atol
        frames = int(off.reshape(len(off), -1).any(axis=1).sum()) if off.ndim > 1 else int(off.sum())
        problems.append(f"{_describe(key)}: max difference {diff[index]:.6g} at "
                        f"{_where(key, index)}: {a[index]:.9g}, golden {g[index]:.9g} "
                        f"({int(off.sum())} values in {frames} frames beyond atol={atol:g})")
    if problems:
        raise AssertionError(f"playback differs from the golden file {path}:\n  "
                             + "\n  ".join(problems)
                             + f"\n(to accept the new playback: update=True, pytest "
                               f"--update-golden or {UPDATE_ENV}=1)")
