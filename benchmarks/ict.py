"""The ICT-FaceKit head as a benchmark face for Facial Motion Cloning.

The data (``<shared>/data/ict-facekit/ict_facekit_light.npz``, see its README) is read
in place, never copied into the repository: ``<shared>`` is the argument given, else
``$MPEG4FBA_SHARED``, else ``<repo>/../shared``.  Units are centimetres, y up, +z toward
the viewer, so the face's own left is +x.

* :func:`load_ict` -> :class:`IctData` (generic neutral, triangles, 53 ARKit expression
  deltas, 20 identity deltas, sub-mesh vertex ranges, 68 Multi-PIE landmarks);
  :func:`identity` makes a random person, ``neutral + sum(w_i * delta_i)``.
* :func:`ict_face` splits the head into a :class:`~mpeg4fba.fba.face.FaceModel`
  (meshes at the root, no transforms) with feature points; :func:`mesh_layout` says which
  original vertices each mesh holds, :func:`split_deltas` / :func:`join` move per-vertex
  arrays between the full ICT numbering and the meshes.  Each face also keeps the
  original ids in ``face.regions["ict_ids:<mesh>"]``.
* :func:`decimate` (vertex clustering whose clusters are represented by one *original*
  vertex, so a decimated vertex's ground truth is exactly its original's delta) and
  :func:`ict_face_decimated` (the Skin decimated, the other meshes kept).
* :func:`skin_regions` (mouth, eyes, brows, rest) and :func:`flipped_triangles` for
  measuring results.
* :data:`LANDMARK_POINTS`, the table of which MPEG-4 feature points ICT's 68 Multi-PIE
  landmarks define (and how), :func:`landmark_points` (them on any identity) and
  :func:`landmark_truth` (given points: the landmarks' where they define a point, our
  picked ones elsewhere): the truth of ``benchmarks/bench_find_points.py``.
* Heads as users give them: :class:`Placement` / :func:`random_placement` (up +Y or +Z,
  facing any horizontal axis, tilted up to 20 degrees, scale 0.1, 1 or 10) and
  :func:`placed_face` (moved, eyeballs dropped on request, points stripped).

The decimation, the landmark table and the placements are written in
:mod:`benchmarks.ict_decimate`, :mod:`benchmarks.ict_landmarks` and
:mod:`benchmarks.ict_placed`; every name is imported from here.

Mesh split (checked on the data, see :func:`mesh_layout`): ``face`` + ``head_neck`` are
the Skin; ``teeth`` is 32 connected components, one per tooth, grouped into UpperTeeth and
LowerTeeth (16 each) by the largest gap between the component centroids' heights;
``gums_tongue`` is one connected component (tongue, palate and both gums joined), kept as
one mesh, GumsTongue; ``narrow_face`` (vertices 0-6705) is a subset of ``face`` and is
dropped.  Of the 52,220 triangles, 719 cross ranges: the 403 joining face and head_neck
are inside the Skin; the 316 seam triangles joining the face to the mouth socket (148)
and to the eye sockets (84 + 84) lie in no single mesh and are dropped
(:attr:`IctLayout.dropped`).

Decimation of the generic Skin to 0.25 (:func:`ict_face_decimated`): 11,248 -> 2,794
vertices and 22,288 -> 5,490 triangles.  The grid is uniform and the front of the face is
the densest part, so the ``face`` range keeps 17 % of its vertices and ``head_neck`` 66 %
(only 6 % of the decimated front triangles are original triangles); 36 triangles (0.7 %)
face against the original surface normals (ears, nostrils, lip and eye corners); the lips
are not welded (no edge stretches more than 2.2 times under jawOpen).

Feature points: vertex ids of the generic neutral in ``spec_fixtures/ict/feature_points.json``
(made by ``benchmarks/ict_pick_points.py``, which documents the rule of each), except 7.1
(top of the spine), which no vertex marks; see :func:`spine_top`.

>>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
>>> T = np.array([[0, 1, 2], [1, 3, 2]])
>>> flipped_triangles(V, V * [1, -1, 1], T), flipped_triangles(V, V * 2, T)
(2, 0)
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Mapping, Optional, Sequence, Union

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.featurepoints import FeaturePointSet
from mpeg4fba.cloning.surface import vertex_normals  # noqa: F401  (re-exported)

__all__ = ["IctData", "IctLayout", "load_ict", "load_or_say", "shared_root", "ict_path", "identity",
           "mesh_layout", "ict_face", "ict_face_decimated", "split_deltas", "join",
           "feature_point_ids", "spine_top", "line_hits", "decimate", "decimation_report",
           "skin_regions", "flipped_triangles", "vertex_normals", "MESH_NAMES", "FP_JSON",
           "IDS_PREFIX", "SKIN_FRONT", "REGION_NAMES", "REGION_RULES",
           "LANDMARK_POINTS", "LANDMARK_CONTOUR", "LANDMARK_RING", "LANDMARK_PICKED_TOLERANCE",
           "landmark_points", "landmark_truth", "Placement", "random_placement", "placed_face",
           "UP_AXES", "FACING_AXES", "SCALES", "MAX_TILT", "EYEBALLS"]

REPO = Path(__file__).resolve().parents[1]
#: The data file, relative to the shared folder.
ICT_RELATIVE = Path("data") / "ict-facekit" / "ict_facekit_light.npz"
#: Our feature point choice: MPEG-4 id -> vertex id of the generic neutral.
FP_JSON = REPO / "spec_fixtures" / "ict" / "feature_points.json"
#: ``face.regions`` key prefix of each mesh's original ICT vertex ids.
IDS_PREFIX = "ict_ids:"
#: ``face.regions`` key of the Skin vertices of the ICT ``face`` range (the front area).
SKIN_FRONT = "ict_range_face:Skin"
#: Mesh name of each ICT range (``teeth`` is split in two; ``narrow_face`` is dropped).
MESH_NAMES = {
    "face": "Skin", "head_neck": "Skin", "mouth_socket": "MouthSocket",
    "eye_socket_L": "LeftEyeSocket", "eye_socket_R": "RightEyeSocket",
    "gums_tongue": "GumsTongue", "teeth": ("UpperTeeth", "LowerTeeth"),
    "eyeball_L": "LeftEyeball", "eyeball_R": "RightEyeball",
    "lacrimal_L": "LeftLacrimal", "lacrimal_R": "RightLacrimal",
    "eye_blend_L": "LeftEyeBlend", "eye_blend_R": "RightEyeBlend",
    "eye_occl_L": "LeftEyeOcclusion", "eye_occl_R": "RightEyeOcclusion",
    "eyelashes_L": "LeftEyelashes", "eyelashes_R": "RightEyelashes",
}
DROPPED_RANGES = ("narrow_face",)
REGION_NAMES = ("mouth", "eyes", "brows", "rest")


# -- data ---------------------------------------------------------------------------------
def shared_root(shared: Optional[Path] = None) -> Path:
    """The shared data folder: ``shared``, else ``$MPEG4FBA_SHARED``, else ``<repo>/../shared``."""
    if shared is not None:
        return Path(shared)
    env = os.environ.get("MPEG4FBA_SHARED")
    return Path(env) if env else REPO.parent / "shared"


def ict_path(shared: Optional[Path] = None) -> Path:
    """Path of ``ict_facekit_light.npz`` under the shared folder (may not exist)."""
    return shared_root(shared) / ICT_RELATIVE


@dataclass(eq=False)
class IctData:
    """The ICT-FaceKit arrays, float64: ``neutral`` (n, 3), ``triangles`` (m, 3) (the
    fan-triangulated quads), ``expressions`` name -> (n, 3) delta, ``identity_deltas``
    (20, n, 3) named by ``identity_names``, ``ranges`` range name -> (first, last) vertex
    ids (inclusive), ``landmarks`` the 68 Multi-PIE vertex ids (iBUG order)."""

    neutral: np.ndarray
    triangles: np.ndarray
    expressions: dict
    identity_names: tuple
    identity_deltas: np.ndarray
    ranges: dict
    landmarks: np.ndarray
    source_commit: str = ""
    path: Optional[Path] = None

    @property
    def n_vertices(self) -> int:
        return len(self.neutral)

    def expression_deltas(self, names: Optional[Sequence[str]] = None) -> np.ndarray:
        """Deltas of ``names`` (default all, in order) stacked as (k, n, 3)."""
        names = list(self.expressions) if names is None else list(names)
        return np.stack([self.expressions[k] for k in names])


def load_ict(shared: Optional[Path] = None) -> IctData:
    """Read ``<shared>/data/ict-facekit/ict_facekit_light.npz`` into an :class:`IctData`.

    Raises FileNotFoundError naming the path when the file is absent."""
    path = ict_path(shared)
    if not path.is_file():
        raise FileNotFoundError(
            f"ICT-FaceKit data not found: {path} does not exist (give the shared folder, or "
            "set MPEG4FBA_SHARED to it; the default is <repo>/../shared)")
    with np.load(path, allow_pickle=False) as z:
        names = [str(s) for s in z["expression_names"]]
        ex = z["expression_deltas"].astype(np.float64)
        ranges = {k: (int(a), int(b)) for k, (a, b) in json.loads(str(z["ranges_json"])).items()}
        return IctData(
            neutral=z["neutral"].astype(np.float64),
            triangles=z["tris"].astype(np.int64),
            expressions={k: ex[i] for i, k in enumerate(names)},
            identity_names=tuple(str(s) for s in z["identity_names"]),
            identity_deltas=z["identity_deltas"].astype(np.float64),
            ranges=ranges,
            landmarks=z["landmarks_multipie68"].astype(np.int64),
            source_commit=str(z["source_commit"]) if "source_commit" in z.files else "",
            path=path)


def load_or_say(shared: Optional[Path] = None) -> Optional[IctData]:
    """:func:`load_ict`, or None after printing why it is skipped (a benchmark without
    ``../shared`` says so and exits 0)."""
    try:
        return load_ict(shared)
    except FileNotFoundError as e:
        print(f"skipped: {e}")
        return None


def identity(data: IctData, seed: int, scale: float = 1.0) -> np.ndarray:
    """A random person: ``neutral + sum(w_i * delta_i)``, ``w ~ N(0, 1) * scale`` drawn
    from ``numpy.random.default_rng(seed)``; (n, 3) float64."""
    w = np.random.default_rng(seed).standard_normal(len(data.identity_deltas)) * scale
    return data.neutral + np.einsum("i,inc->nc", w, data.identity_deltas)


# -- graph helpers --------------------------------------------------------------------------
def vertex_adjacency(triangles: np.ndarray, n: int) -> sp.csr_matrix:
    """Symmetric vertex adjacency (n, n) of a triangle list."""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    a = t.ravel()
    b = t[:, [1, 2, 0]].ravel()
    A = sp.coo_matrix((np.ones(2 * len(a)), (np.r_[a, b], np.r_[b, a])), shape=(n, n))
    return A.tocsr()


def _components(triangles: np.ndarray, n: int) -> np.ndarray:
    """Connected component label of every vertex (isolated vertices are their own)."""
    return connected_components(vertex_adjacency(triangles, n), directed=False)[1]


def triangle_cross(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Each triangle's edge cross product (twice its area along its unnormalised normal)."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return np.cross(V[..., T[:, 1], :] - V[..., T[:, 0], :], V[..., T[:, 2], :] - V[..., T[:, 0], :])


def flipped_triangles(neutral: np.ndarray, animated: np.ndarray, triangles: np.ndarray) -> int:
    """How many triangles' normals turn by more than 90 degrees from ``neutral`` to
    ``animated`` (both (n, 3)); degenerate triangles (zero normal) are not counted."""
    a = triangle_cross(neutral, triangles)
    b = triangle_cross(animated, triangles)
    return int(np.count_nonzero(np.einsum("ij,ij->i", a, b) < 0))


# -- the mesh split -------------------------------------------------------------------------
@dataclass(eq=False)
class IctLayout:
    """How the ICT head is split into meshes.

    ``ids[mesh]``: original vertex ids of the mesh (sorted; local vertex i is original
    ``ids[mesh][i]``); ``triangles[mesh]``: its triangles in local numbering;
    ``vertex_mesh`` (n,) the mesh name index (into ``meshes``) of each original vertex and
    ``local_index`` (n,) its index in that mesh; ``dropped`` (k, 3) original triangles in
    no mesh (their vertices lie in two meshes) with ``dropped_pairs`` counting them by
    range pair; ``findings`` the component counts met while splitting."""

    meshes: tuple
    ids: dict
    triangles: dict
    vertex_mesh: np.ndarray
    local_index: np.ndarray
    dropped: np.ndarray
    dropped_pairs: dict
    findings: dict = field(default_factory=dict)

    @property
    def n_vertices(self) -> int:
        return len(self.vertex_mesh)

    def locate(self, vertex_ids) -> list:
        """``[(mesh, local index)]`` of original vertex ids."""
        v = np.atleast_1d(np.asarray(vertex_ids, dtype=np.int64))
        return [(self.meshes[m], int(i)) for m, i in zip(self.vertex_mesh[v], self.local_index[v])]


def _split_teeth(ids: np.ndarray, neutral: np.ndarray, triangles: np.ndarray) -> tuple:
    """(upper ids, lower ids, components, upper components) of the teeth range: components
    grouped by the largest gap between their centroids' heights."""
    n = len(neutral)
    inside = np.zeros(n, dtype=bool)
    inside[ids] = True
    tris = triangles[inside[triangles].all(axis=1)]
    label = _components(tris, n)[ids]
    comps, inv = np.unique(label, return_inverse=True)
    cy = np.bincount(inv, weights=neutral[ids, 1]) / np.bincount(inv)
    if len(comps) < 2:
        raise ValueError("the teeth range is one connected component; can't tell upper from lower")
    order = np.sort(cy)
    gap = int(np.argmax(np.diff(order)))
    cut = 0.5 * (order[gap] + order[gap + 1])
    upper = cy[inv] > cut
    return ids[upper], ids[~upper], len(comps), int((cy > cut).sum())


@lru_cache(maxsize=2)
def mesh_layout(data: IctData) -> IctLayout:
    """Split ``data`` into meshes (see the module docstring); cached per ``data``.

    Every vertex is in exactly one mesh.  A triangle goes to the mesh of its first vertex
    when all three of its vertices are in that mesh, else to :attr:`IctLayout.dropped`."""
    n = data.n_vertices
    T = data.triangles
    range_of = np.full(n, -1, dtype=np.int64)
    rnames = [r for r in data.ranges if r not in DROPPED_RANGES]
    for i, r in enumerate(rnames):
        a, b = data.ranges[r]
        if (range_of[a:b + 1] >= 0).any():
            raise ValueError(f"ICT range {r} overlaps another one")
        range_of[a:b + 1] = i
    if (range_of < 0).any():
        raise ValueError(f"{int((range_of < 0).sum())} ICT vertices are in no range")
    unknown = [r for r in rnames if r not in MESH_NAMES]
    if unknown:
        raise ValueError(f"ICT ranges without a mesh name: {unknown}")

    names: list = []
    vertex_mesh = np.full(n, -1, dtype=np.int64)
    findings: dict = {}

    def add(name: str, ids: np.ndarray) -> None:
        if name not in names:
            names.append(name)
        vertex_mesh[ids] = names.index(name)

    for r in rnames:
        a, b = data.ranges[r]
        ids = np.arange(a, b + 1)
        if r == "teeth":
            upper, lower, k, ku = _split_teeth(ids, data.neutral, T)
            findings["teeth components"] = k
            findings["upper teeth components"] = ku
            findings["upper teeth vertices"] = len(upper)
            findings["lower teeth vertices"] = len(lower)
            add(MESH_NAMES[r][0], upper)
            add(MESH_NAMES[r][1], lower)
            continue
        if r == "gums_tongue":
            inside = np.zeros(n, dtype=bool)
            inside[ids] = True
            lab = _components(T[inside[T].all(axis=1)], n)[ids]
            findings["gums_tongue components"] = len(np.unique(lab))
        add(MESH_NAMES[r], ids)

    meshes = tuple(names)
    tm = vertex_mesh[T]
    own = (tm == tm[:, :1]).all(axis=1)
    ids = {m: np.flatnonzero(vertex_mesh == k) for k, m in enumerate(meshes)}
    local_index = np.empty(n, dtype=np.int64)
    for m in meshes:
        local_index[ids[m]] = np.arange(len(ids[m]))
    triangles = {m: local_index[T[own & (tm[:, 0] == k)]] for k, m in enumerate(meshes)}
    dropped = T[~own]
    pairs: dict = {}
    if len(dropped):
        rd = np.sort(range_of[dropped], axis=1)
        keys, counts = np.unique(np.c_[rd[:, 0], rd[:, -1]], axis=0, return_counts=True)
        pairs = {f"{rnames[a]}+{rnames[b]}": int(c) for (a, b), c in zip(keys, counts)}
    rt = range_of[T]
    findings["triangles crossing ranges"] = int((rt != rt[:, :1]).any(axis=1).sum())
    return IctLayout(meshes, ids, triangles, vertex_mesh, local_index, dropped, pairs, findings)


def _ids_of(face_or_layout: Union[FaceModel, IctLayout, Mapping]) -> dict:
    """Mesh -> original ids from a face (its ``ict_ids:`` regions), a layout or a mapping."""
    if isinstance(face_or_layout, IctLayout):
        return dict(face_or_layout.ids)
    if isinstance(face_or_layout, FaceModel):
        out = {k[len(IDS_PREFIX):]: np.asarray(v) for k, v in face_or_layout.regions.items()
               if k.startswith(IDS_PREFIX)}
        if not out:
            raise ValueError(f"face {face_or_layout.name} has no '{IDS_PREFIX}<mesh>' regions: "
                             "it was not made by benchmarks.ict")
        return out
    return {k: np.asarray(v) for k, v in face_or_layout.items()}


def split_deltas(face_or_layout: Union[FaceModel, IctLayout, Mapping],
                 full: np.ndarray) -> dict:
    """Per-vertex arrays on the full ICT numbering, (n, 3) or (k, n, 3), sliced per mesh:
    ``{mesh: (n_mesh, 3) or (k, n_mesh, 3)}`` (decimated meshes get their kept vertices)."""
    full = np.asarray(full)
    return {m: full[..., ids, :] for m, ids in _ids_of(face_or_layout).items()}


def join(face_or_layout: Union[FaceModel, IctLayout, Mapping], parts: Mapping,
         n_vertices: Optional[int] = None, fill: float = 0.0) -> np.ndarray:
    """Inverse of :func:`split_deltas`: per-mesh arrays back on the full ICT numbering,
    (n, 3) or (k, n, 3); vertices of no given mesh (decimated away, or meshes left out)
    get ``fill``.  ``n_vertices`` defaults to the layout's (largest id + 1 for a face)."""
    ids = _ids_of(face_or_layout)
    if n_vertices is None:
        n_vertices = (face_or_layout.n_vertices if isinstance(face_or_layout, IctLayout)
                      else max(int(v.max()) + 1 for v in ids.values() if len(v)))
    first = np.asarray(next(iter(parts.values())))
    out = np.full(first.shape[:-2] + (n_vertices, 3), fill, dtype=np.result_type(first, float))
    for m, arr in parts.items():
        out[..., ids[m], :] = arr
    return out


# -- feature points -------------------------------------------------------------------------
def feature_point_ids(path: Optional[Path] = None) -> dict:
    """MPEG-4 feature point id -> ICT vertex id, from ``spec_fixtures/ict/feature_points.json``."""
    path = Path(path) if path is not None else FP_JSON
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    return {k: int(v) for k, v in doc["points"].items()}


def line_hits(vertices: np.ndarray, triangles: np.ndarray, x: float, y: float) -> np.ndarray:
    """z of every point where the line {(x, y, z)} meets the triangles (sorted).

    >>> V = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 2], [0, 0, 5], [2, 0, 5], [0, 2, 5]], float)
    >>> line_hits(V, np.array([[0, 1, 2], [3, 4, 5]]), 0.5, 0.5).tolist()
    [0.5, 5.0]
    """
    P = np.asarray(vertices, dtype=np.float64)[np.asarray(triangles, dtype=np.int64)]
    a, b, c = P[:, 0, :2], P[:, 1, :2], P[:, 2, :2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    ok = np.abs(det) > 1e-15
    det = np.where(ok, det, 1.0)
    u = ((x - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (y - a[:, 1])) / det
    v = ((b[:, 0] - a[:, 0]) * (y - a[:, 1]) - (x - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
    w = 1.0 - u - v
    hit = ok & (u >= 0) & (v >= 0) & (w >= 0)
    z = w * P[:, 0, 2] + u * P[:, 1, 2] + v * P[:, 2, 2]
    return np.sort(z[hit])


def spine_top(vertices: np.ndarray, ids: Mapping, skin_triangles: np.ndarray) -> np.ndarray:
    """Feature point 7.1, the top of the spine (the head's centre of rotation), which no
    vertex marks.  From the full ICT vertex array:

    * x: midway between the pupils (3.5, 3.6), i.e. on the head's mid plane;
    * y: the height of the bottom of the nose, 9.15.  The top of the dens and the
      occipital condyles (where the skull rocks on the atlas) lie close to the palatal
      plane (McGregor's / Chamberlain's lines run from the hard palate to the skull base),
      and the subnasale sits at that plane;
    * z: midway between the front (throat) and the back (nape) of the neck on the mid
      plane, where the line (x, y_n, z) meets the Skin first and last, y_n one quarter of
      the eye separation (ES0, about 1.6 cm) below the bottom of the chin (2.1), where
      the neck is free of the jaw: the cervical spine runs about through the middle of
      the neck.

    On the generic head this gives (0, -1.20, -0.33) cm: on the mid plane, 1.7 cm below
    and 1.4 cm behind the openings of the ear canals (about (+-6.5, 0.5, 1.1)), about
    where the occipital condyles sit at the bottom of the skull.

    ``ids`` maps feature points to vertex ids (3.5, 3.6, 9.15, 2.1 are used);
    ``skin_triangles`` are the Skin's triangles in the ICT numbering."""
    V = np.asarray(vertices, dtype=np.float64)
    p35, p36, p915, p21 = (V[ids[k]] for k in ("3.5", "3.6", "9.15", "2.1"))
    x = 0.5 * (p35[0] + p36[0])
    y_neck = p21[1] - 0.25 * abs(p35[0] - p36[0])
    z = line_hits(V, skin_triangles, x, y_neck)
    if len(z) < 2:
        raise ValueError(f"the mid line at the neck (y = {y_neck:.3f}) meets the Skin "
                         f"{len(z)} times; can't place 7.1")
    return np.array([x, p915[1], 0.5 * (z[0] + z[-1])])


def _points(data: IctData, layout: IctLayout, vertices: np.ndarray, fp_ids: Mapping,
            tongue_tip: bool) -> tuple:
    """(positions, ties) of the feature points, ties in the full layout's numbering."""
    ids = {k: v for k, v in fp_ids.items() if tongue_tip or not k.startswith("6.")}
    pos = {k: vertices[v] for k, v in ids.items()}
    ties = dict(zip(ids, layout.locate(list(ids.values()))))
    pos["7.1"] = spine_top(vertices, fp_ids, layout.ids["Skin"][layout.triangles["Skin"]])
    return pos, ties


def ict_face(data: IctData, vertices: Optional[np.ndarray] = None, *, name: str = "ict",
             fp_ids: Optional[Mapping] = None, tongue_tip: bool = False) -> FaceModel:
    """The head ``vertices`` ((n, 3) on the ICT numbering, default the generic neutral)
    as a FaceModel: the meshes of :func:`mesh_layout` at the root (no transforms), feature
    points tied to their vertices (7.1 computed, :func:`spine_top`), and regions
    ``ict_ids:<mesh>`` (original ids) and :data:`SKIN_FRONT`.

    6.1 (tongue tip) lies on GumsTongue, which also holds the gums and palate; it is left
    out unless ``tongue_tip`` (a cloner would take GumsTongue for a rigid tongue)."""
    V = data.neutral if vertices is None else np.asarray(vertices, dtype=np.float64)
    if V.shape != data.neutral.shape:
        raise ValueError(f"vertices must be {data.neutral.shape}, not {V.shape}")
    layout = mesh_layout(data)
    fp_ids = feature_point_ids() if fp_ids is None else fp_ids
    meshes = [FaceMesh(m, V[layout.ids[m]], layout.triangles[m]) for m in layout.meshes]
    pos, ties = _points(data, layout, V, fp_ids, tongue_tip)
    face = FaceModel(meshes, points=FeaturePointSet(pos, ties), name=name)
    for m in layout.meshes:
        face.regions[IDS_PREFIX + m] = layout.ids[m]
    a, b = data.ranges["face"]
    skin = layout.ids["Skin"]
    face.regions[SKIN_FRONT] = np.flatnonzero((skin >= a) & (skin <= b))
    return face


# -- regions --------------------------------------------------------------------------------
def _polyline_distance(P: np.ndarray, points: np.ndarray, closed: bool) -> np.ndarray:
    """Distance of each row of ``P`` (n, 3) to a 3D polyline through ``points`` (k, 3)."""
    A = np.asarray(points, dtype=np.float64)
    B = np.roll(A, -1, axis=0) if closed else A[1:]
    A = A if closed else A[:-1]
    AB = B - A
    t = np.einsum("nkc,kc->nk", P[:, None, :] - A[None], AB) / np.maximum((AB * AB).sum(1), 1e-300)
    Q = A[None] + np.clip(t, 0, 1)[..., None] * AB[None]
    return np.linalg.norm(P[:, None, :] - Q, axis=2).min(axis=1)


#: Polylines (feature points) and radii (fractions of ES0) of :func:`skin_regions`.
REGION_RULES = {
    "mouth": ([["8.4", "8.6", "8.9", "8.1", "8.10", "8.5", "8.3", "8.7", "8.2", "8.8"],
               ["2.5", "2.7", "2.2", "2.6", "2.4", "2.8", "2.3", "2.9"]], True, 0.15),
    "eyes": ([["3.11", "3.1", "3.7", "3.3"], ["3.8", "3.2", "3.12", "3.4"]], True, 0.12),
    "brows": ([["4.1", "4.3", "4.5"], ["4.2", "4.4", "4.6"]], False, 0.10),
}


def skin_regions(face: FaceModel) -> dict:
    """Skin vertex indices of the regions ``mouth``, ``eyes``, ``brows`` and ``rest``
    (a partition of the Skin mesh's vertices).

    Only the front area (the ICT ``face`` range, :data:`SKIN_FRONT`) is split; the rest
    of the head goes to ``rest``.  A front vertex is in ``mouth`` when within 0.15 ES0
    (about 1 cm) of the outer lip contour (8.4 8.6 8.9 8.1 8.10 8.5 8.3 8.7 8.2 8.8,
    closed) or the inner one (2.x), else in ``eyes`` when within 0.12 ES0 of an eye
    opening (3.11 3.1 3.7 3.3 and 3.8 3.2 3.12 3.4, closed), else in ``brows`` when
    within 0.10 ES0 of a brow line (4.1 4.3 4.5 and 4.2 4.4 4.6); distances in 3D.
    Defined from feature points only, so decimated faces get them too."""
    V = face.meshes["Skin"].vertices
    pts = face.points
    es = float(pts["3.5"][0] - pts["3.6"][0])
    front = np.zeros(len(V), dtype=bool)
    front[face.regions.get(SKIN_FRONT, np.arange(len(V)))] = True
    free = front.copy()
    out = {}
    for region, (lines, closed, radius) in REGION_RULES.items():
        d = np.min([_polyline_distance(V, np.array([pts[p] for p in line]), closed)
                    for line in lines], axis=0)
        take = free & (d < radius * es)
        out[region] = np.flatnonzero(take)
        free &= ~take
    out["rest"] = np.flatnonzero(free | ~front)
    return out


# the decimated heads, the landmark table and the heads as users give them live in
# modules of their own, which build on this one; their names are found here too, on first
# use (``ict.placed_face``), where the benchmarks and tests look for them
_ELSEWHERE = {
    "ict_decimate": ("decimate", "decimation_report", "ict_face_decimated"),
    "ict_landmarks": ("LANDMARK_CONTOUR", "LANDMARK_PICKED_TOLERANCE", "LANDMARK_POINTS",
                      "LANDMARK_RING", "landmark_points", "landmark_truth"),
    "ict_placed": ("EYEBALLS", "FACING_AXES", "MAX_TILT", "SCALES", "UP_AXES", "Placement",
                   "axis_vector", "cut_at_seams", "jaw_fat", "placed_face", "random_placement"),
}
_WHERE = {name: module for module, names in _ELSEWHERE.items() for name in names}


def __getattr__(name: str):
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib
    return getattr(importlib.import_module(f"{__package__}.{module}"), name)
