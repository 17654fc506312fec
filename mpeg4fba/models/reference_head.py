"""The procedural reference head: a complete MPEG-4 face, generated in code.

:func:`reference_head` builds a :class:`~mpeg4fba.fba.face.FaceModel` with

* a smooth skin mesh of the whole head and neck (about 11,000 triangles at
  ``resolution=1``) with a mouth slit between separate upper and lower lips and two
  eye openings between upper and lower lids; hair over the skull;
* eyeballs (with iris and pupil) each under its own Transform (``LeftEye``,
  ``RightEye``, translation = the eye's centre), upper teeth, lower teeth and a tongue
  under the ``Jaw`` Transform (centre = the jaw hinge), a dark mouth cavity, and a
  thin hidden rod carrying the top of the spine; all under ``Head``, whose centre is
  feature point 7.1;
* all 84 feature points, each a vertex of the mesh the standard puts it on (FDP
  positions and (mesh, vertex) ties), from which the FAPU follow;
* a FAT for every low-level FAP (3-68) in which each FAP moves its feature point by
  exactly value x FAPU along its direction (turns by value x 1e-5 rad), with smooth,
  region-limited influence round it (see :mod:`mpeg4fba.models._rig`), and tables for
  the 14 visemes and 6 expressions made from documented FAP combinations
  (:mod:`mpeg4fba.models.shapes`).

Units are metres (VRML's), the face frame is the standard's: x = the face's left,
y = up, z = forward (the gaze); y = 0 at the pupils, z = 0 about the ear canals.
The face also carries ``face.colors`` (a colour per vertex of each mesh: skin, lips,
brows, hair, iris, teeth and gums...) for :func:`mpeg4fba.render.render_face`, and
``face.regions`` (Skin vertex indices: the upper and lower lips and the areas round
them, each eye's lids, and the inner lip contours and lid margins as matching upper and
lower halves).

Nothing is read from files: the head is the same for the same arguments, to the bit.

Example
-------
>>> face = reference_head(resolution=0.5)
>>> len(face.points), sorted(face.transforms)
(84, ['Head', 'Jaw', 'LeftEye', 'RightEye'])
>>> round(face.fapu.MW0 * 1000, 1)            # mouth width, mm
50.0
>>> face.fat[3].meshes[0].mesh, face.fat[3].transforms[0].transform
('Skin', 'Jaw')
>>> len(face.fat.visemes), len(face.fat.expressions)
(14, 6)
"""
from __future__ import annotations

import copy
from functools import lru_cache

import numpy as np

from ..fba.face import FaceMesh, FaceModel, FaceTransform
from ..fba.fapu import FAPU
from ..fba.fat import FAT
from ..fba.featurepoints import FeaturePointSet
from ..fba.tables import FEATURE_POINTS
from ._parts import BROW, HAIR, LIP, SKIN, eyeball, hairline, mouth_cavity, teeth
# (the part builders named as the parts they make, which are local names here)
from ._parts import hair as hair_mesh, spine as spine_mesh, tongue as tongue_mesh
from ._rig import low_level_tables
from ._shape import Design, smoothstep
from ._skin import PATCH_LEFT_EYE, PATCH_MOUTH, PATCH_RIGHT_EYE, build_skin
from .shapes import high_level_tables

__all__ = ["reference_head", "MESHES", "TRANSFORMS", "UNIT"]

#: Model units per millimetre: the head is built in millimetres and delivered in metres.
UNIT = 1e-3

#: The head's meshes and the Transform each hangs under.
MESHES = {"Skin": "Head", "Hair": "Head", "LeftEyeball": "LeftEye", "RightEyeball": "RightEye",
          "UpperTeeth": "Head", "LowerTeeth": "Jaw", "Tongue": "Jaw", "Mouth": "Head",
          "Spine": "Head"}
#: Its Transforms and their parents.
TRANSFORMS = {"Head": None, "Jaw": "Head", "LeftEye": "Head", "RightEye": "Head"}

_NAMES = {"skin": "Skin", "hair": "Hair", "jaw": "Jaw", "head": "Head", "left_eye": "LeftEye",
          "right_eye": "RightEye", "left_eyeball": "LeftEyeball",
          "right_eyeball": "RightEyeball", "tongue": "Tongue"}


def _skin_colors(skin, d: Design) -> np.ndarray:
    """Skin colour with lips, brows, a touch of colour on the cheeks, hair."""
    V = skin.vertices
    points = {k: V[i] for k, i in skin.points.items()}
    x, y, z = V.T
    col = np.tile(SKIN, (len(V), 1))
    mouth = skin.patch == PATCH_MOUTH
    # lips: the vermilion (t <= 1) and the tuck, shading into skin at the border
    lip = np.where(mouth, 1.0 - smoothstep((skin.t - 0.92) / 0.16), 0.0)
    col = col * (1 - lip[:, None]) + LIP * lip[:, None]
    # cheeks
    for sgn in (1, -1):
        dist = np.linalg.norm(V - points["5.1" if sgn > 0 else "5.2"], axis=1)
        blush = 0.10 * (1 - smoothstep(dist / 22.0))
        col = col * (1 - blush[:, None]) + np.array([0.85, 0.50, 0.48]) * blush[:, None]
    # brows: a band along the curve through 4.1, 4.3, 4.5 (4.2, 4.4, 4.6)
    for sgn, ids in ((1, ("4.1", "4.3", "4.5")), (-1, ("4.2", "4.4", "4.6"))):
        p = np.array([points[k] for k in ids])
        curve = np.polyfit(p[:, 0] * sgn, p[:, 1], 2)
        u = x * sgn
        b = (u - p[0, 0] * sgn) / ((p[2, 0] - p[0, 0]) * sgn)
        centre = np.polyval(curve, u) - 3.0
        half = 3.6 * (1 - 0.55 * smoothstep((b - 0.25) / 0.8)) + 0.8 * (1 - smoothstep(b / 0.3))
        inside = (1 - smoothstep((np.abs(y - centre) - half + 0.8) / 2.6)) \
            * smoothstep((b + 0.06) / 0.08) * (1 - smoothstep((b - 1.02) / 0.08)) * (z > 40)
        lids = ((skin.patch == PATCH_LEFT_EYE) | (skin.patch == PATCH_RIGHT_EYE)) & (skin.t < 1.3)
        inside = inside * ~lids
        col = col * (1 - 0.8 * inside[:, None]) + BROW * 0.8 * inside[:, None]
    # under the hair
    under = smoothstep((hairline(x, y, z) + 4.0) / 11.0)
    col = col * (1 - under[:, None]) + HAIR * under[:, None]
    return col


def reference_head(*, face_width: float = 1.0, jaw: float = 1.0, nose: float = 1.0,
                   eye_spacing: float = 1.0, mouth_width: float = 1.0, resolution: float = 1.0,
                   seed: int = 0) -> FaceModel:
    """Build the reference head.

    ``face_width``, ``jaw``, ``nose``, ``eye_spacing`` and ``mouth_width`` (each 0.8 to
    1.25) change its proportions; ``resolution`` (0.5 to 4) the density of its meshes
    (the skin has about 11,000 triangles at 1); ``seed`` the jitter of the skin's
    background vertices (so another seed gives another triangulation of the same
    shape).  Deterministic: the same arguments give the same arrays.  The last few heads
    built are kept, and each call gets its own copy (a build takes most of a second; the
    test suite asks for the same few heads a hundred times); ``reference_head.cache_clear()``
    forgets them.
    """
    if not 0.5 <= float(resolution) <= 4.0:
        raise ValueError(f"resolution = {resolution}: the reference head takes 0.5 to 4")
    return copy.deepcopy(_build(float(face_width), float(jaw), float(nose), float(eye_spacing),
                                float(mouth_width), float(resolution), int(seed)))


@lru_cache(maxsize=6)
def _build(face_width: float, jaw: float, nose: float, eye_spacing: float, mouth_width: float,
           resolution: float, seed: int) -> FaceModel:
    d = Design(face_width, jaw, nose, eye_spacing, mouth_width)
    skin = build_skin(d, float(resolution), int(seed))
    V = skin.vertices
    # teeth, tongue and mouth behind the lips
    lips_z = V[skin.points["2.2"], 2]
    teeth_z = lips_z - 10.5
    eye = eyeball(d, resolution)
    upper = teeth(d, teeth_z, True, resolution)
    lower = teeth(d, teeth_z, False, resolution)
    tip_z = lower.vertices[lower.points["9.11"], 2] - 3.0
    tongue = tongue_mesh(d, tip_z, resolution)
    mouth = mouth_cavity(d, teeth_z, resolution)
    spine = spine_mesh(d)
    skin_colors = _skin_colors(skin, d)
    hair, hair_over = hair_mesh(V, skin.triangles, skin_colors)
    skin_i = skin.points["11.4"]
    hair_top = int(np.flatnonzero(hair_over == skin_i)[0])
    centres = {"LeftEye": d.eye_centre(1), "RightEye": d.eye_centre(-1)}
    # feature points: (mesh, vertex) and positions in the face frame (mm)
    ties = {k: ("Skin", v) for k, v in skin.points.items()}
    ties.update({"3.5": ("LeftEyeball", eye.points["pupil"]),
                 "3.6": ("RightEyeball", eye.points["pupil"]), "11.5": ("Hair", hair_top)})
    ties.update({k: ("UpperTeeth", v) for k, v in upper.points.items()})
    ties.update({k: ("LowerTeeth", v) for k, v in lower.points.items()})
    ties.update({k: ("Tongue", v) for k, v in tongue.points.items()})
    ties.update({k: ("Spine", v) for k, v in spine.points.items()})
    meshes_mm = {"Skin": V, "Hair": hair.vertices, "LeftEyeball": eye.vertices,
                 "RightEyeball": eye.vertices, "UpperTeeth": upper.vertices,
                 "LowerTeeth": lower.vertices, "Tongue": tongue.vertices,
                 "Mouth": mouth.vertices, "Spine": spine.vertices}
    offset = {"LeftEyeball": centres["LeftEye"], "RightEyeball": centres["RightEye"]}
    positions = {k: meshes_mm[m][i] + offset.get(m, 0.0) for k, (m, i) in ties.items()}
    missing = [fp.id for fp in FEATURE_POINTS if fp.id not in positions]
    if missing:
        raise AssertionError(f"feature points {missing} were not placed")
    fapu_mm = FAPU.from_feature_points(positions)
    tables = low_level_tables(d, skin, positions, fapu_mm,
                              {"eye": eye, "tongue": tongue, "hair_over": hair_over}, _NAMES)
    # the model, in metres
    u = UNIT
    transforms = [FaceTransform("Head", None, center=tuple(d.spine_top * u)),
                  FaceTransform("Jaw", "Head", center=tuple(d.hinge * u)),
                  FaceTransform("LeftEye", "Head", translation=tuple(centres["LeftEye"] * u)),
                  FaceTransform("RightEye", "Head", translation=tuple(centres["RightEye"] * u))]
    parts = {"Skin": (V, skin.triangles), "Hair": (hair.vertices, hair.triangles),
             "LeftEyeball": (eye.vertices, eye.triangles),
             "RightEyeball": (eye.vertices, eye.triangles),
             "UpperTeeth": (upper.vertices, upper.triangles),
             "LowerTeeth": (lower.vertices, lower.triangles),
             "Tongue": (tongue.vertices, tongue.triangles), "Mouth": (mouth.vertices, mouth.triangles),
             "Spine": (spine.vertices, spine.triangles)}
    meshes = [FaceMesh(name, v * u, t, MESHES[name]) for name, (v, t) in parts.items()]
    for table in tables:
        for m in table.meshes:
            m.displacements = m.displacements * u
        for t in table.transforms:
            if t.field == "translation":
                t.translation = tuple(np.asarray(t.translation) * u)
    points = FeaturePointSet({k: p * u for k, p in positions.items()}, ties)
    face = FaceModel(meshes, transforms, points, fat=FAT(tables), name="reference_head")
    for table in high_level_tables(face):
        face.fat.add(table)
    face.invalidate()
    face.colors = {"Skin": skin_colors, "Hair": hair.colors,
                   "LeftEyeball": eye.colors, "RightEyeball": eye.colors,
                   "UpperTeeth": upper.colors, "LowerTeeth": lower.colors,
                   "Tongue": tongue.colors, "Mouth": mouth.colors, "Spine": spine.colors}
    m = skin.patch == PATCH_MOUTH
    face.regions = {
        "upper_lip": np.flatnonzero(m & (skin.side > 0) & (skin.t <= 1.0)),
        "lower_lip": np.flatnonzero(m & (skin.side < 0) & (skin.t <= 1.0)),
        "upper_lip_area": np.flatnonzero(m & (skin.side > 0)),
        "lower_lip_area": np.flatnonzero(m & (skin.side < 0)),
        "left_eye_lids": np.flatnonzero(skin.patch == PATCH_LEFT_EYE),
        "right_eye_lids": np.flatnonzero(skin.patch == PATCH_RIGHT_EYE),
    }
    # the inner lip contours and the lid margins, upper and lower halves in matching
    # order (k-th upper vertex above the k-th lower one)
    index = skin.extras["index"]
    for name, kind, ring in (("lips", PATCH_MOUTH, 3), ("left_margin", PATCH_LEFT_EYE, 2),
                             ("right_margin", PATCH_RIGHT_EYE, 2)):
        row = index[kind][ring]
        n = len(row) // 2
        face.regions[name + "_upper"] = row[1:n]
        face.regions[name + "_lower"] = row[2 * n - 1:n:-1]
    return face


#: Forget the heads kept (a benchmark timing the build itself calls it before each build).
reference_head.cache_clear = _build.cache_clear
