"""FBA compliance rules: findings with stable codes, and the numeric FAP check.

Each rule has a code that never changes meaning, a severity (``error`` or ``warning``)
and a location (file:line where the object came from text).  The rules that need the
text of a file (node types, where a node is) live with the file readers, in
:mod:`mpeg4fba.formats.validate`; here are the rules on objects.

The numeric check is one no other tool has: each low-level FAP of the FAT is played
alone at a test value, and the feature point it moves (the vertex it is tied to, else
the vertex nearest to it; of a closed slit's two copies of that place, the one the FAP
moves) must move along the FAP's direction by value x FAPU / 1024 (a rotation FAP must
turn its Transform by value x 1e-5 rad).  The ratio of what it does to what the
standard says is reported per FAP; more than 5% off is flagged.

Example
-------
>>> from mpeg4fba.fba.face import FaceMesh, FaceModel
>>> from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
>>> RULES["FBA008"].title
'interval borders not strictly increasing or without a 0'
"""
from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field
from typing import Optional

import numpy as np

from .._location import where_text
from .face import FaceModel
from .fapu import FAPU
from .requirements import required_points
from .tables import FAP

__all__ = ["Rule", "RULES", "Finding", "Report", "check_fat", "check_fap_ratios",
           "fap_ratios", "TEST_VALUE"]


@dataclass(frozen=True)
class Rule:
    code: str
    severity: str
    title: str


RULES = {r.code: r for r in [
    Rule("FBA001", "error", "Face node without an FDP"),
    Rule("FBA002", "error", "feature points missing that the FAT's FAPs need"),
    Rule("FBA003", "error", "FAPU not computable or not positive"),
    Rule("FBA004", "error", "fapID outside 1-68"),
    Rule("FBA005", "error", "highLevelSelect outside the range for FAP 1 (1-14) or FAP 2 (1-6)"),
    Rule("FBA006", "error", "FaceDefMesh target is not an IndexedFaceSet of the face scene graph"),
    Rule("FBA007", "error", "vertex index out of range"),
    Rule("FBA008", "error", "interval borders not strictly increasing or without a 0"),
    Rule("FBA009", "error", "displacement count is not (borders - 1) x vertices"),
    Rule("FBA010", "error", "FaceDefTransform target is not a Transform of the face scene graph"),
    Rule("FBA011", "error", "FaceDefTransform fieldId is not 1, 2 or 3"),
    Rule("FBA012", "error", "two tables for the same FAP (or the same viseme/expression)"),
    Rule("FBA013", "warning", "a one-sided FAP given negative interval borders"),
    Rule("FBA014", "warning", "FAP moves its feature point off the standard's measure"),
    Rule("FBA015", "error", "not a face: no Face node"),
    Rule("FBA016", "warning", "FAP with a table that moves nothing at the test value"),
    Rule("FBA017", "warning", "face in a mesh file (glTF, OBJ) without feature points: the "
                              "feature point, FAPU and numeric FAP checks skipped"),
    Rule("FBA100", "error", "face file can't be read"),
    Rule("FBA101", "error", "FAP stream file can't be read"),
    Rule("FBA102", "warning", "FAP stream value outside the standard's range"),
    Rule("FBA103", "warning", "FAP stream read with a repair (frame count, numbering, columns)"),
]}

#: The FAP value the numeric check plays each FAP at (in FAP units): large enough to
#: measure, inside every bidirectional range.
TEST_VALUE = 512.0


@dataclass
class Finding:
    """One problem: rule ``code``, ``severity``, ``message`` and where (path, line, column)."""

    code: str
    message: str
    path: Optional[str] = None
    line: Optional[int] = None
    column: Optional[int] = None
    severity: str = ""
    data: dict = field(default_factory=dict)

    def __post_init__(self):
        if not self.severity:
            self.severity = RULES[self.code].severity

    def where(self) -> str:
        return where_text(self.path, self.line, self.column, "<face>")

    def __str__(self) -> str:
        return f"{self.where()}: {self.severity} {self.code}: {self.message}"

    def as_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if v not in (None, {}, "")}


@dataclass
class Report:
    """Findings about one file or object, plus the per-FAP ratios of the numeric check."""

    source: str
    findings: list = field(default_factory=list)
    ratios: dict = field(default_factory=dict)

    @property
    def errors(self) -> list:
        return [f for f in self.findings if f.severity == "error"]

    @property
    def ok(self) -> bool:
        return not self.errors

    def as_dict(self) -> dict:
        return {"source": self.source, "ok": self.ok,
                "findings": [f.as_dict() for f in self.findings],
                "fap_ratios": {str(k): v for k, v in self.ratios.items()}}

    def __str__(self) -> str:
        lines = [str(f) for f in self.findings]
        head = f"{self.source}: " + ("OK" if not self.findings else
                                     f"{len(self.errors)} error(s), "
                                     f"{len(self.findings) - len(self.errors)} warning(s)")
        return "\n".join([head] + ["  " + line for line in lines])


def _loc(face: FaceModel, obj) -> dict:
    """path/line/column of an object read from text, when the reader recorded it."""
    src = getattr(face, "source", None) or {}
    where = {"path": src.get("path")}
    node = (src.get("nodes") or {}).get(id(obj))
    loc = getattr(node, "location", None)
    if loc is not None:
        where.update(path=loc[0] or where["path"], line=loc[1], column=loc[2])
    return where


def check_fat(face: FaceModel) -> list:
    """Findings about a FaceModel's FAT, feature points and FAPU (rules on objects)."""
    out = []
    seen: dict = {}
    for table in face.fat:
        at = _loc(face, table)
        if not 1 <= table.fap <= 68:
            out.append(Finding("FBA004", f"fapID {table.fap} is outside 1-68", **at))
            continue
        if table.fap in (1, 2):
            top = 14 if table.fap == 1 else 6
            if not 1 <= table.select <= top:
                what = "viseme" if table.fap == 1 else "expression"
                out.append(Finding("FBA005", f"FAP {table.fap} table selects {what} "
                                   f"{table.select}; the {what}s are 1-{top}", **at))
        key = table.key
        if key in seen:
            what = f"FAP {table.fap}" + (f" select {table.select}" if table.fap <= 2 else "")
            out.append(Finding("FBA012", f"a second table for {what} (the first is at "
                               f"{seen[key]})", **at))
        else:
            seen[key] = Finding("FBA012", "", **at).where()
        record = FAP[table.fap]
        for m in table.meshes:
            mat = _loc(face, m) if _loc(face, m).get("line") else at
            mesh = face.meshes.get(m.mesh)
            if mesh is None:
                out.append(Finding("FBA006", f"FAP {table.fap}: FaceDefMesh deforms {m.mesh!r}, "
                                   "which is not a mesh of the face", **mat))
                continue
            b = m.borders
            if len(b) < 2 or not (np.diff(b) > 0).all() or not (b == 0).any():
                out.append(Finding("FBA008", f"FAP {table.fap}: interval borders {b.tolist()} "
                                   + ("are not strictly increasing" if len(b) >= 2 and not
                                      (np.diff(b) > 0).all() else "have no 0"), **mat))
            elif record.unidirectional and b[0] < 0:
                out.append(Finding("FBA013", f"FAP {table.fap} {record.name} is one-sided "
                                   f"(0 and up) but its borders start at {b[0]:g}", **mat))
            n_int = max(len(b) - 1, 0)
            if m.displacements.size != len(m.indices) * n_int * 3:
                out.append(Finding("FBA009", f"FAP {table.fap} on {m.mesh}: "
                                   f"{m.displacements.size // 3} displacements for "
                                   f"{len(m.indices)} vertices x {n_int} intervals (expected "
                                   f"{len(m.indices) * n_int})", **mat))
            n = len(mesh.vertices)
            bad = m.indices[(m.indices < 0) | (m.indices >= n)]
            if len(bad):
                out.append(Finding("FBA007", f"FAP {table.fap} on {m.mesh}: vertex index "
                                   f"{int(bad[0])} out of range ({n} vertices)"
                                   + (f" and {len(bad) - 1} more" if len(bad) > 1 else ""), **mat))
        for t in table.transforms:
            if t.transform not in face.transforms:
                out.append(Finding("FBA010", f"FAP {table.fap}: FaceDefTransform drives "
                                   f"{t.transform!r}, which is not a Transform of the face", **at))
    # Feature points the FAT's FAPs need (the list cloning checks too), and the FAPU.
    missing = face.points.missing(required_points(face.fat.faps))
    src = {"path": (getattr(face, "source", None) or {}).get("path")}
    if missing:
        out.append(Finding("FBA002", f"feature point{'s' if len(missing) > 1 else ''} "
                           f"{', '.join(missing)} missing (needed by the FAT's FAPs)",
                           data={"missing": missing}, **src))
    problem = None
    fapu = face._fapu
    if fapu is None:
        try:
            with warnings.catch_warnings():  # what is wrong is reported here, not warned
                warnings.simplefilter("ignore")
                fapu = FAPU.from_feature_points(face.points)
        except ValueError as e:
            problem = str(e)
    if fapu is not None:
        bad = [k for k, v in fapu.as_dict().items() if not v > 0]
        if bad:
            problem = ", ".join(f"{k} = {fapu.as_dict()[k]:g}" for k in bad) + " (not positive)"
    if problem and len(face.fat):
        out.append(Finding("FBA003", f"FAPU: {problem}", **src))
    return out


def fap_ratios(face: FaceModel, value: float = TEST_VALUE) -> dict:
    """Per low-level FAP with a table: what it does at ``value`` over what it should.

    For a translation FAP: the displacement of its feature point's vertex (see
    :func:`_translation_ratio`), projected on the FAP's axis, over value x FAPU unit.
    For a rotation FAP: the angle its Transform turns by, over value x 1e-5.  A
    one-sided FAP is played at +value, a FAP whose table only has negative intervals at
    -value.  None where it can't be measured (no feature point position, no FAPU,
    scale/curl FAPs).
    """
    fapu = face.fapu
    out: dict = {}
    if fapu is None:
        return out
    for table in face.fat:
        if not 3 <= table.fap <= 68 or table.fap in out:
            continue
        r = FAP[table.fap]
        borders = np.concatenate([m.borders for m in table.meshes]) if table.meshes else np.zeros(0)
        p = -value if len(borders) and borders.max() <= 0 else value
        if r.motion == "translation" and table.meshes:
            out[table.fap] = _translation_ratio(face, table, r, p, fapu.unit(r))
        elif r.motion == "rotation" and table.transforms:
            out[table.fap] = _rotation_ratio(face, table, p)
        else:
            out[table.fap] = None
    return out


#: Vertices this close to a feature point's nearest vertex (a fraction of ES0) are the
#: same place: a closed slit (a mouth, an eye) duplicates its vertices along the seam,
#: one copy per lip or lid, and a point on the seam belongs to both sides.
SEAM = 1e-3


def _measuring_vertices(face: FaceModel, fp: str, es0: float) -> list:
    """(mesh, vertex) candidates whose motion measures a FAP of feature point ``fp``: its
    vertex (the one the point is tied to, else the nearest of all meshes) and that
    vertex's copies (any vertex within :data:`SEAM` x ES0 of it)."""
    if fp not in face.points:
        return []
    worlds = {name: face.world_vertices(name) for name in face.meshes}
    tie = face.points.vertex(fp)
    if tie is not None and tie[0] in worlds and 0 <= tie[1] < len(worlds[tie[0]]):
        at = worlds[tie[0]][tie[1]]
    else:
        target = np.asarray(face.points[fp], dtype=np.float64)
        best = None
        for name, w in worlds.items():
            if len(w):
                i = int(np.argmin(np.linalg.norm(w - target, axis=1)))
                d = float(np.linalg.norm(w[i] - target))
                if best is None or d < best[0]:
                    best = (d, w[i])
        if best is None:
            return []
        at = best[1]
    return [(name, int(i)) for name, w in worlds.items() if len(w)
            for i in np.flatnonzero(np.linalg.norm(w - at, axis=1) <= SEAM * es0)]


def _translation_ratio(face, table, record, p, unit) -> Optional[float]:
    """The measured ratio at the feature point's vertex; on a seam (several vertices at
    the point, see :data:`SEAM`) the copy the FAP moves most along its axis: the FAP of
    the upper lip acts on the upper lip's copy, the lower lip's FAP on the lower one's
    (the standard puts the point on the seam and leaves the copies to the model)."""
    from .stream import FapStream
    fp = record.feature_point
    hits = _measuring_vertices(face, fp, face.fapu.ES0 if face.fapu is not None else 0.0)
    if not hits or unit <= 0:
        return None
    play = face.play(FapStream.from_values({table.fap: [0.0, p]}, fps=1))
    axis = np.asarray(record.axis, float)
    expected = p * unit
    if not expected:
        return None
    best = None
    for mesh, index in hits:
        w = play.world_vertices(mesh)
        along = float(np.dot(w[1, index] - w[0, index], axis))
        if best is None or abs(along) > abs(best):
            best = along
    return best / expected


def _rotation_ratio(face, table, p) -> Optional[float]:
    from .stream import FapStream
    play = face.play(FapStream.from_values({table.fap: [0.0, p]}, fps=1))
    name = table.transforms[0].transform
    R0 = play.transform(name)["rotation"][0]
    R1 = play.transform(name)["rotation"][1]
    dR = R1 @ R0.T
    angle = float(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1.0, 1.0)))
    return angle / abs(p * 1e-5)


def check_fap_ratios(face: FaceModel, tolerance: float = 0.05, value: float = TEST_VALUE) -> tuple:
    """(findings, ratios): FBA014 for each FAP more than ``tolerance`` off, FBA016 for a
    table that moves nothing."""
    ratios = fap_ratios(face, value)
    out = []
    for fap, ratio in sorted(ratios.items()):
        if ratio is None:
            continue
        table = face.fat[fap]
        at = _loc(face, table)
        name = FAP[fap].name
        if abs(ratio) < 1e-12:
            out.append(Finding("FBA016", f"FAP {fap} {name}: its table moves feature point "
                               f"{FAP[fap].feature_point} not at all", data={"ratio": ratio}, **at))
        elif abs(ratio - 1) > tolerance:
            out.append(Finding("FBA014", f"FAP {fap} {name}: moves by {ratio:.3f} x the "
                               f"standard's measure (value x FAPU/1024 along "
                               f"{FAP[fap].positive_motion}); more than {tolerance:.0%} off",
                               data={"ratio": ratio}, **at))
    return out, ratios
