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
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable
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
def _adjacency(triangles: np.ndarray, n: int) -> sp.csr_matrix:
    """Symmetric vertex adjacency (n, n) of a triangle list."""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    a = t.ravel()
    b = t[:, [1, 2, 0]].ravel()
    A = sp.coo_matrix((np.ones(2 * len(a)), (np.r_[a, b], np.r_[b, a])), shape=(n, n))
    return A.tocsr()


def _components(triangles: np.ndarray, n: int) -> np.ndarray:
    """Connected component label of every vertex (isolated vertices are their own)."""
    return connected_components(_adjacency(triangles, n), directed=False)[1]


def _triangle_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return np.cross(V[..., T[:, 1], :] - V[..., T[:, 0], :], V[..., T[:, 2], :] - V[..., T[:, 0], :])


def flipped_triangles(neutral: np.ndarray, animated: np.ndarray, triangles: np.ndarray) -> int:
    """How many triangles' normals turn by more than 90 degrees from ``neutral`` to
    ``animated`` (both (n, 3)); degenerate triangles (zero normal) are not counted."""
    a = _triangle_normals(neutral, triangles)
    b = _triangle_normals(animated, triangles)
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


# -- decimation -----------------------------------------------------------------------------
def _clusters(V: np.ndarray, cell: float, origin: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Cluster label per vertex: the connected pieces of each grid cell."""
    key = np.floor((V - origin) / cell).astype(np.int64)
    _, cell_id = np.unique(key, axis=0, return_inverse=True)
    cell_id = cell_id.ravel()
    e = edges[cell_id[edges[:, 0]] == cell_id[edges[:, 1]]]
    n = len(V)
    A = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return connected_components(A, directed=False)[1]


def decimate(vertices: np.ndarray, triangles: np.ndarray, target_fraction: float = 0.25, *,
             keep: Sequence[int] = (), tolerance: float = 0.01) -> tuple:
    """Vertex-clustering decimation in which each cluster is one ORIGINAL vertex.

    The vertices are binned in a uniform grid whose cell size is found by bisection (on a
    log scale) so that about ``target_fraction`` of them remain (within ``tolerance``
    relative, or the closest found).  A cluster is a connected piece of a cell (vertices
    of one cell joined by mesh edges inside it), so surfaces that touch without sharing
    edges (closed lips, eyelids) are not welded.  Its representative is the member
    nearest to the cluster's centroid, or the member listed in ``keep`` (a cluster with
    several ``keep`` members is split between them, each member going to the nearest).
    Triangles are mapped to representatives; degenerate (repeated vertex or zero area)
    and duplicate ones (same vertex set) are dropped, and representatives left in no
    triangle are dropped unless kept.

    Returns ``(kept_ids, triangles)``: sorted ids into ``vertices`` and (m', 3)
    triangles numbered into ``kept_ids``.

    >>> g = np.stack(np.meshgrid(np.arange(20.0), np.arange(20.0)), -1).reshape(-1, 2)
    >>> V = np.c_[g, np.zeros(len(g))]
    >>> q = (np.arange(19)[:, None] * 20 + np.arange(19)).ravel()
    >>> T = np.r_[np.c_[q, q + 1, q + 21], np.c_[q, q + 21, q + 20]]
    >>> kept, tris = decimate(V, T, 0.25, keep=[0, 1])
    >>> abs(len(kept) / 400 - 0.25) < 0.05, {0, 1} <= set(kept.tolist()), len(tris) > 0
    (True, True, True)
    >>> bool((np.cross(V[kept][tris[:, 1]] - V[kept][tris[:, 0]],
    ...                V[kept][tris[:, 2]] - V[kept][tris[:, 0]])[:, 2] > 0).all())
    True
    """
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n = len(V)
    keep = np.unique(np.asarray(keep, dtype=np.int64))
    edges = np.unique(np.sort(np.r_[T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]], axis=1), axis=0)
    target = max(1, int(round(target_fraction * n)))
    origin = V.min(axis=0)
    mean_edge = float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
    lo, hi = 0.05 * mean_edge, float(np.ptp(V, axis=0).max()) + 1e-9
    best = None
    for _ in range(40):
        cell = float(np.sqrt(lo * hi))
        label = _clusters(V, cell, origin, edges)
        count = int(label.max()) + 1
        if best is None or abs(count - target) < abs(best[1] - target):
            best = (label, count)
        if abs(count - target) <= tolerance * target:
            break
        if count > target:
            lo = cell
        else:
            hi = cell
    label = best[0]

    # clusters holding several kept vertices: split them between those vertices
    is_keep = np.zeros(n, dtype=bool)
    is_keep[keep] = True
    nkeep = np.bincount(label, weights=is_keep, minlength=label.max() + 1)
    multi = np.flatnonzero(nkeep[label] >= 2)
    if len(multi):
        K = keep[nkeep[label[keep]] >= 2]
        d = np.linalg.norm(V[multi, None, :] - V[None, K, :], axis=2)
        d[label[multi][:, None] != label[K][None, :]] = np.inf
        label = label.copy()
        label[multi] = label.max() + 1 + np.argmin(d, axis=1)
        _, label = np.unique(label, return_inverse=True)
        label = label.ravel()

    # representative: the kept member, else the member nearest the centroid
    k = label.max() + 1
    size = np.bincount(label, minlength=k)
    centroid = np.stack([np.bincount(label, weights=V[:, c], minlength=k) for c in range(3)], 1)
    centroid /= size[:, None]
    score = np.linalg.norm(V - centroid[label], axis=1)
    score[is_keep] = -1.0
    order = np.lexsort((np.arange(n), score, label))
    first = order[np.r_[True, label[order][1:] != label[order][:-1]]]
    rep = np.empty(k, dtype=np.int64)
    rep[label[first]] = first

    # triangles on the representatives: no degenerate, no duplicate
    R = rep[label][T]
    ok = (R[:, 0] != R[:, 1]) & (R[:, 1] != R[:, 2]) & (R[:, 2] != R[:, 0])
    R = R[ok]
    area2 = np.linalg.norm(_triangle_normals(V, R), axis=1)
    R = R[area2 > 1e-12 * max(mean_edge, 1e-300) ** 2]
    _, first_of = np.unique(np.sort(R, axis=1), axis=0, return_index=True)
    R = R[np.sort(first_of)]
    used = np.zeros(n, dtype=bool)
    used[R.ravel()] = True
    used[keep] = True
    kept = np.flatnonzero(used)                   # every used vertex is a representative
    new = np.full(n, -1, dtype=np.int64)
    new[kept] = np.arange(len(kept))
    return kept, new[R]


def decimation_report(vertices: np.ndarray, triangles: np.ndarray, kept: np.ndarray,
                      new_triangles: np.ndarray) -> dict:
    """Counts describing a :func:`decimate` result: vertices and triangles before and
    after, how many decimated triangles are also original triangles, how many face away
    from the original surface (normal against the mean original vertex normal of their
    corners), zero-area ones, and edges with more than two triangles (non-manifold)."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    kept = np.asarray(kept)
    R = kept[np.asarray(new_triangles)]
    N = vertex_normals(V, T)
    fn = _triangle_normals(V, R)
    flipped = int(np.count_nonzero(np.einsum("ij,ij->i", fn, N[R].sum(axis=1)) < 0))
    n = np.int64(len(V))

    def code(t):
        s = np.sort(t, axis=1).astype(np.int64)
        return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]
    shared = np.count_nonzero(np.isin(code(R), code(T)))
    e = np.sort(np.r_[R[:, [0, 1]], R[:, [1, 2]], R[:, [2, 0]]], axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    return {"vertices": len(V), "triangles": len(T), "kept_vertices": len(kept),
            "kept_triangles": len(R), "vertex_fraction": len(kept) / max(len(V), 1),
            "triangles_also_original": int(shared), "flipped_vs_original_normals": flipped,
            "zero_area": int(np.count_nonzero(np.linalg.norm(fn, axis=1) == 0)),
            "nonmanifold_edges": int(np.count_nonzero(cnt > 2)),
            "boundary_edges": int(np.count_nonzero(cnt == 1))}


def ict_face_decimated(data: IctData, vertices: Optional[np.ndarray] = None,
                       fraction: float = 0.25, *, name: str = "ict_decimated",
                       fp_ids: Optional[Mapping] = None, tongue_tip: bool = False,
                       keep_ids: Sequence[int] = ()) -> FaceModel:
    """:func:`ict_face` with its Skin decimated to about ``fraction`` of its vertices
    (:func:`decimate` on ``vertices``, feature point vertices kept, their ties renumbered;
    the other meshes unchanged).  ``face.regions["ict_ids:Skin"]`` holds the original ids
    of the kept Skin vertices, so ground truth is ``split_deltas(face, delta)``.
    ``keep_ids``: more original (ICT) vertex ids to keep, where on the Skin (e.g. the
    landmarks, ``data.landmarks``)."""
    face = ict_face(data, vertices, name=name, fp_ids=fp_ids, tongue_tip=tongue_tip)
    skin = face.meshes["Skin"]
    ties = face.points.vertices
    on_skin = {k: i for k, (m, i) in ties.items() if m == "Skin"}
    ids = face.regions[IDS_PREFIX + "Skin"]
    extra = np.searchsorted(ids, np.asarray(keep_ids, dtype=np.int64))
    extra = extra[(extra < len(ids)) & (ids[np.minimum(extra, len(ids) - 1)] == np.asarray(keep_ids, dtype=np.int64))]
    kept, tris = decimate(skin.vertices, skin.triangles, fraction,
                          keep=list(on_skin.values()) + extra.tolist())
    face.meshes["Skin"] = FaceMesh("Skin", skin.vertices[kept], tris, skin.parent)
    ids = face.regions[IDS_PREFIX + "Skin"]
    front = np.zeros(len(ids), dtype=bool)
    front[face.regions[SKIN_FRONT]] = True
    face.regions[IDS_PREFIX + "Skin"] = ids[kept]
    face.regions[SKIN_FRONT] = np.flatnonzero(front[kept])
    where = np.searchsorted(kept, list(on_skin.values()))
    ties.update({k: ("Skin", int(w)) for k, w in zip(on_skin, where)})
    pos = {k: face.points[k] for k in face.points}
    face.points = FeaturePointSet(pos, ties)
    face.invalidate()
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


# -- the 68 landmarks as MPEG-4 feature points --------------------------------------------------
#: Which MPEG-4 feature points ICT's 68 Multi-PIE / iBUG landmarks define, as data:
#: ``fp -> (rule, landmarks, note)``.  Landmark numbering (checked on the data, see
#: ``benchmarks/ict_pick_points.py``): 0-16 jaw contour, 17-21 the face's RIGHT brow (17
#: outer), 22-26 its LEFT brow (22 inner), 27-30 nose bridge down to the tip, 31-35 the
#: nostril base (31 right end, 33 middle, 35 left end), 36-41 the RIGHT eye (36 outer
#: corner, 37-38 upper lid, 39 inner corner, 40-41 lower lid), 42-47 the LEFT eye (42
#: inner corner, 43-44 upper lid, 45 outer corner, 46-47 lower lid), 48-59 the outer lip
#: contour (48 right corner, 51 upper middle, 54 left corner, 57 lower middle), 60-67 the
#: inner one (60 right corner, 62 upper middle, 64 left corner, 66 lower middle).  The
#: face's own left is +x (the standard's "left" is the face's, not the viewer's: 3.5 is
#: the left pupil, ES0 = 3.5.x - 3.6.x > 0).
#:
#: Rules: ``at`` the landmark's vertex; ``between`` the point at half the arc length of
#: the polyline through the landmarks (the spec's "midpoint between A and B on the
#: contour", and a lid's centre between its two lid landmarks), projected onto the Skin
#: triangles around those landmarks (within :data:`LANDMARK_RING` mesh edges: the lips
#: and lids are separate sheets that touch without sharing edges, so a point between two
#: upper-lip landmarks lands on the upper lip).  Checked against the spec's definitions
#: (``<shared>/spec/feature_points.csv``) and against our picked points
#: (:data:`FP_JSON`) by ``tests/test_find_points_ict.py``; the distance to the picked
#: point is in :data:`LANDMARK_PICKED_TOLERANCE`.
LANDMARK_POINTS = {
    "2.1": ("at", (8,), "bottom of the chin; a jaw-contour landmark: VIEW-DEPENDENT in an "
                        "image, a fixed vertex here (the chin's lowest midline point)"),
    "2.2": ("at", (62,), "middle of the inner upper lip contour"),
    "2.3": ("at", (66,), "middle of the inner lower lip contour"),
    "2.4": ("at", (64,), "left corner of the inner lip contour"),
    "2.5": ("at", (60,), "right corner of the inner lip contour"),
    "2.6": ("between", (62, 63, 64), "inner upper lip, midpoint between 2.2 and 2.4 (landmark "
                                     "63 itself is 1.4 mm nearer the middle)"),
    "2.7": ("between", (62, 61, 60), "inner upper lip, midpoint between 2.2 and 2.5"),
    "2.8": ("between", (66, 65, 64), "inner lower lip, midpoint between 2.3 and 2.4"),
    "2.9": ("between", (66, 67, 60), "inner lower lip, midpoint between 2.3 and 2.5"),
    "2.11": ("at", (9,), "chin left corner; jaw-contour landmark: VIEW-DEPENDENT"),
    "2.12": ("at", (7,), "chin right corner; jaw-contour landmark: VIEW-DEPENDENT"),
    "3.1": ("between", (43, 44), "centre of the upper left lid margin (its two landmarks)"),
    "3.2": ("between", (38, 37), "centre of the upper right lid margin"),
    "3.3": ("between", (47, 46), "centre of the lower left lid margin"),
    "3.4": ("between", (40, 41), "centre of the lower right lid margin"),
    "3.7": ("at", (45,), "outer corner of the left eye"),
    "3.8": ("at", (39,), "inner corner of the right eye"),
    "3.11": ("at", (42,), "inner corner of the left eye"),
    "3.12": ("at", (36,), "outer corner of the right eye"),
    "4.1": ("at", (22,), "inner end of the left brow"),
    "4.2": ("at", (21,), "inner end of the right brow"),
    "4.3": ("at", (24,), "uppermost point of the left brow: its middle landmark (the highest "
                         "of 22-26 on the generic head; a flat maximum, so not 'the highest')"),
    "4.4": ("at", (19,), "uppermost point of the right brow: its middle landmark"),
    "4.5": ("at", (26,), "outer end of the left brow"),
    "4.6": ("at", (17,), "outer end of the right brow"),
    "8.1": ("at", (51,), "middle of the outer upper lip contour"),
    "8.2": ("at", (57,), "middle of the outer lower lip contour"),
    "8.3": ("at", (54,), "left corner of the outer lip contour"),
    "8.4": ("at", (48,), "right corner of the outer lip contour"),
    "8.5": ("between", (51, 52, 53, 54), "outer upper lip, midpoint between 8.1 and 8.3"),
    "8.6": ("between", (51, 50, 49, 48), "outer upper lip, midpoint between 8.1 and 8.4"),
    "8.7": ("between", (57, 56, 55, 54), "outer lower lip, midpoint between 8.2 and 8.3"),
    "8.8": ("between", (57, 58, 59, 48), "outer lower lip, midpoint between 8.2 and 8.4"),
    "8.9": ("at", (50,), "right high point of the Cupid's bow"),
    "8.10": ("at", (52,), "left high point of the Cupid's bow"),
    "9.3": ("at", (30,), "nose tip (the bridge's last landmark).  AMBIGUOUS: the tip is flat, "
                         "landmark 30 sits 3 mm above the front-most vertex (our picked 9.3) "
                         "and 0.2 mm behind it"),
    "9.4": ("at", (31,), "bottom right edge of the nose (right end of the nostril base)"),
    "9.5": ("at", (35,), "bottom left edge of the nose (left end of the nostril base)"),
    "9.15": ("at", (33,), "bottom middle edge of the nose (subnasale)"),
}
#: Points of :data:`LANDMARK_POINTS` from jaw-contour landmarks (0-16): a contour landmark
#: is where the face's outline is seen in a picture, so it slides with the view; ICT fixes
#: it to a vertex (seen from the front).  Reported apart.
LANDMARK_CONTOUR = ("2.1", "2.11", "2.12")
#: Not defined by the landmarks (checked for plausibility only): 2.10 chin boss, 2.13/2.14
#: jaw corners (contour landmarks 3-5 / 11-13 lie on the outline, not at the gonion),
#: 3.5/3.6 pupils, 3.9/3.10 and 3.13/3.14 the outer lids (no landmark off the lid
#: margins), 5.x cheeks, 9.1/9.2 the alae (31/35 are the nostril base's ends, 9.4/9.5),
#: 9.6/9.7 and 9.12-9.14 the nose bone (27-29 lie evenly along the bridge, not at its
#: edges or bump), teeth, tongue, ears, hair line, 7.1.
#: Mesh edges around a ``between`` rule's landmarks whose triangles it is projected onto.
LANDMARK_RING = 3
#: fp -> the largest distance (cm, generic head) allowed between a landmark point and our
#: picked point (:data:`FP_JSON`), with why they differ: 0 where the picked point IS the
#: landmark; else the measured difference rounded up (see tests/test_find_points_ict.py).
LANDMARK_PICKED_TOLERANCE = {
    **{fp: 1e-6 for fp, (rule, _, _) in LANDMARK_POINTS.items() if rule == "at"},
    "9.3": 0.35,      # picked: the front-most vertex; landmark 30 is 3.1 mm above it
    "2.6": 0.20, "2.7": 0.20, "2.8": 0.20, "2.9": 0.20,       # picked: lowest/highest in a slab
    #                        halfway in x; here halfway along the lip (1.4 and 1.9 mm further out)
    "8.5": 0.10, "8.6": 0.10, "8.7": 0.10, "8.8": 0.10,       # picked: the nearest vertex
    "3.1": 0.25, "3.2": 0.25, "3.3": 0.25, "3.4": 0.25,       # picked: the slab through the pupil
}


def _rings(triangles: np.ndarray, n: int, seeds: Sequence[int], k: int) -> np.ndarray:
    """Vertices within ``k`` mesh edges of ``seeds``."""
    A = _adjacency(triangles, n)
    mask = np.zeros(n, dtype=bool)
    mask[list(seeds)] = True
    for _ in range(k):
        mask = mask | (A @ mask.astype(np.float64) > 0)
    return mask


def _arc_half(Q: np.ndarray) -> np.ndarray:
    """The point at half the arc length of the polyline through ``Q`` (k, 3)."""
    seg = np.linalg.norm(np.diff(Q, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    half = 0.5 * s[-1]
    i = min(int(np.searchsorted(s, half, side="right")) - 1, len(seg) - 1)
    return Q[i] + (half - s[i]) / max(seg[i], 1e-300) * (Q[i + 1] - Q[i])


def landmark_points(data: IctData, vertices: Optional[np.ndarray] = None) -> dict:
    """The feature points ICT's landmarks define (:data:`LANDMARK_POINTS`) on the head
    ``vertices`` ((n, 3) on the full ICT numbering, default the generic neutral), in its
    own frame: ``{fp: (3,) position}`` on the full-resolution Skin surface."""
    from mpeg4fba.cloning.surface import closest_points

    V = data.neutral if vertices is None else np.asarray(vertices, dtype=np.float64)
    layout = mesh_layout(data)
    skin_tris = layout.ids["Skin"][layout.triangles["Skin"]]
    lm = data.landmarks
    out = {}
    for fp, (rule, marks, _) in LANDMARK_POINTS.items():
        ids = lm[list(marks)]
        if rule == "at":
            out[fp] = V[ids[0]].copy()
            continue
        near = _rings(skin_tris, len(V), ids, LANDMARK_RING)
        tris = skin_tris[near[skin_tris].all(axis=1)]
        p = _arc_half(V[ids])
        t, b, _ = closest_points(p[None], V, tris, k=8)
        out[fp] = b[0] @ V[tris[t[0]]]
    return out


def landmark_truth(data: IctData, vertices: Optional[np.ndarray] = None) -> FeaturePointSet:
    """Given points made of the landmarks: :func:`landmark_points` where the landmarks
    define the point, our picked point (:data:`FP_JSON`, 7.1 computed) elsewhere.  Tied
    to no vertex (positions only), for faces of any resolution."""
    face = ict_face(data, vertices)
    pos = {k: face.points[k] for k in face.points}
    pos.update(landmark_points(data, vertices))
    return FeaturePointSet(pos)


# -- heads as users give them ----------------------------------------------------------------
#: The two supported up axes and, for each, the horizontal axes a face may look along.
UP_AXES = {"+Y": (0, 1, 0), "+Z": (0, 0, 1)}
FACING_AXES = {"+Y": ("+X", "-X", "+Z", "-Z"), "+Z": ("+X", "-X", "+Y", "-Y")}
#: The scales a head is given (ICT is in cm: 0.1 looks like dm, 10 like mm).
SCALES = (0.1, 1.0, 10.0)
#: Largest tilt (degrees) off the supported orientations.
MAX_TILT = 20.0
#: The eyeball meshes dropped from a head "without eyes".
EYEBALLS = ("LeftEyeball", "RightEyeball")


def cut_at_seams(face: FaceModel, mesh: str = "Skin") -> tuple:
    """``face`` with ``mesh`` cut into texture islands as a glTF exporter stores a
    textured head: front, back left and back right, every vertex on an island's border
    given once per island (the copies after the mesh's own vertices); (cut face, without
    a FAT, the original vertex of each of the cut mesh's vertices).

    >>> from mpeg4fba.models import reference_head
    >>> head = reference_head(resolution=0.5)
    >>> cut, origin = cut_at_seams(head)
    >>> n = len(head.meshes["Skin"].vertices)
    >>> len(origin) > n, bool((origin[:n] == range(n)).all())
    (True, True)
    """
    m = face.meshes[mesh]
    V, T = m.vertices, m.triangles
    c = V[T].mean(1)
    mid = np.median(V[:, 2])
    island = np.where(c[:, 2] > mid, 0, np.where(c[:, 0] > 0, 1, 2))
    corner = np.repeat(island, 3)
    # the first island to use a vertex keeps it; the others get a copy
    owner = np.full(len(V), -1)
    for k in (0, 1, 2):
        free = (owner[T.ravel()] == -1) & (corner == k)
        owner[T.ravel()[free]] = k
    owner[owner < 0] = 0
    flat = T.ravel()
    key = flat * 3 + corner
    other = corner != owner[flat]
    copies = np.unique(key[other])
    flat = np.where(other, len(V) + np.searchsorted(copies, key), flat)
    origin = np.r_[np.arange(len(V)), copies // 3]
    out = face.copy()
    out.meshes[mesh] = FaceMesh(mesh, V[origin], flat.reshape(-1, 3), m.parent, m.color)
    out.points = FeaturePointSet({k: face.points[k] for k in face.points}, dict(face.points.vertices))
    out.fat = FAT()
    if mesh in face.colors and np.ndim(face.colors[mesh]) == 2:
        out.colors[mesh] = np.asarray(face.colors[mesh])[origin]
    return out, origin


def _axis(name: str) -> np.ndarray:
    v = np.zeros(3)
    v["XYZ".index(name[1])] = 1.0 if name[0] == "+" else -1.0
    return v


@dataclass(frozen=True)
class Placement:
    """Where a head is put: ``world = scale * rotation @ head + offset``.  The head frame
    is ICT's (cm, +y up, +z the way the face looks, +x its left); ``up`` and ``facing``
    name the world axes the head's +y and +z go to before the ``tilt`` (degrees, about
    ``tilt_axis``, a unit vector) is applied.  Rotations are proper (no mirror image)."""

    up: str
    facing: str
    tilt: float
    tilt_axis: tuple
    scale: float
    offset: tuple

    @property
    def rotation(self) -> np.ndarray:
        up, fwd = _axis(self.up), _axis(self.facing)
        R0 = np.c_[np.cross(up, fwd), up, fwd]          # columns: head x, y, z in the world
        a = np.asarray(self.tilt_axis, dtype=np.float64)
        th = np.radians(self.tilt)
        K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        Rt = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
        return Rt @ R0

    def apply(self, P: np.ndarray) -> np.ndarray:
        """Head-frame points (..., 3) -> world."""
        return self.scale * np.asarray(P, dtype=np.float64) @ self.rotation.T + np.asarray(self.offset)

    def undo(self, P: np.ndarray) -> np.ndarray:
        """World points (..., 3) -> the head frame (scale undone)."""
        return (np.asarray(P, dtype=np.float64) - np.asarray(self.offset)) @ self.rotation / self.scale

    @property
    def label(self) -> str:
        return f"up {self.up}, facing {self.facing}, tilt {self.tilt:.0f} deg, x{self.scale:g}"


def random_placement(rng: np.random.Generator) -> Placement:
    """A supported placement: up +Y or +Z (equally likely), facing one of the four
    horizontal axes (equally likely), tilted by U(0, :data:`MAX_TILT`) degrees about a
    uniformly random axis, scaled by one of :data:`SCALES` (equally likely), moved by
    U(-20, 20) cm per axis times the scale.

    >>> p = random_placement(np.random.default_rng(0))
    >>> P = np.array([[1.0, 2, 3]])
    >>> bool(np.allclose(p.undo(p.apply(P)), P)), bool(np.isclose(np.linalg.det(p.rotation), 1))
    (True, True)
    """
    up = str(rng.choice(list(UP_AXES)))
    facing = str(rng.choice(FACING_AXES[up]))
    tilt = float(rng.uniform(0, MAX_TILT))
    a = rng.standard_normal(3)
    a /= np.linalg.norm(a)
    scale = float(rng.choice(SCALES))
    offset = rng.uniform(-20, 20, 3) * scale
    return Placement(up, facing, tilt, tuple(a.tolist()), scale, tuple(offset.tolist()))


def placed_face(face: FaceModel, placement: Optional[Placement] = None, *, eyes: bool = True,
                points: Optional[FeaturePointSet] = None, name: Optional[str] = None) -> FaceModel:
    """A head as a user has it: ``face``'s meshes moved by ``placement`` (default none),
    without the eyeball meshes (:data:`EYEBALLS`) unless ``eyes``, with ``points``
    (moved likewise; default none: a dumb mesh) and no regions, colours or FAT.  The
    meshes keep their names and vertex order (so results map back by index)."""
    meshes = []
    for m in face.meshes.values():
        if not eyes and m.name in EYEBALLS:
            continue
        v = m.vertices if placement is None else placement.apply(m.vertices)
        meshes.append(FaceMesh(m.name, v, m.triangles))
    pts = None
    if points is not None:
        pos = {k: points[k] if placement is None else placement.apply(points[k]) for k in points}
        ties = {k: t for k, t in points.vertices.items() if eyes or t[0] not in EYEBALLS}
        pts = FeaturePointSet(pos, ties)
    return FaceModel(meshes, points=pts, name=name or face.name)


def jaw_fat(data, source: FaceModel) -> FAT:
    """jawOpen of ``data`` as a FAP 3 (open_jaw) table on ``source``, its motion at 1024
    the expression: how the benchmarks see a cloned jaw's rotation."""
    meshes = []
    for mesh, d in split_deltas(source, data.expressions["jawOpen"]).items():
        moving = np.flatnonzero(np.abs(d).max(axis=1) > 0)
        if len(moving):
            meshes.append(FaceDefMesh(mesh, [0, 1024], moving, d[moving][:, None, :] / 1024))
    return FAT([FaceDefTable(3, meshes)])
