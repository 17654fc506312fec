"""Finding the eyes, teeth, tongue and head of a face ("Treating eyes, teeth, tongue and
global motion").

A part's meshes are found from its feature points: the mesh holding one of them (the
point's (mesh, vertex) tie, else the mesh with the vertex nearest the point), plus the
meshes connected to it (sharing a vertex position, within ``weld`` of the face's eye
separation), leaving out meshes that hold another part's or the skin's feature points
- so teeth modelled clenched, upper and lower touching, are still told apart by their
own points.  The head is every mesh of the face.

The Transform that moves each part is :mod:`~mpeg4fba.cloning.part_transforms`'s.

>>> from mpeg4fba.models import reference_head
>>> face = reference_head(resolution=0.5)
>>> found = find_parts(face)
>>> found["lower teeth"], found["left eye"], len(found["head"]) == len(face.meshes)
(['LowerTeeth'], ['LeftEyeball'], True)

Real heads come as one mesh: eyes, teeth and tongue may be welded into the skin's mesh as
separate connected components (:func:`separate_parts` splits them off), or welded to the
skin itself, sharing its vertices.  A part is therefore never a mesh (or component) that
also holds the skin's feature points: an eye whose pupil lies on the skin is no eyeball,
and the head is cloned as skin, without eyeball motion.  An eye must also be roughly
spherical (:func:`is_eyeball`).  Why a component holds a point: it has the surface
nearest to the point (the point's vertex tie, else the closest point of every triangle).
Teeth and tongue are matched by shape to a source face's (:func:`match_parts`): that
finds teeth modelled one component per tooth whole, and the points of parts given none.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Iterable, Optional

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..fba.face import FaceModel
from ..fba.featurepoints import FeaturePointSet
from ..fba.requirements import NOT_SURFACE
from .rigid import sphere_centre
from .surface import closest_points, feature_warp

__all__ = ["PartSpec", "PARTS", "PART_SPECS", "find_parts", "mesh_holding", "connected_meshes",
           "HEAD",
           "mesh_components", "is_eyeball", "EYEBALL_ROUNDNESS", "Components",
           "part_components", "separate_parts", "carry_part_points",
           "match_parts", "MATCHED_KINDS"]


@dataclass(frozen=True)
class PartSpec:
    """A rigid part of the face: ``kind`` is eye, teeth or tongue; ``points`` the feature
    points that identify its meshes (in order of preference); ``riders`` the parts that
    may share its transform."""

    name: str
    kind: str
    points: tuple
    riders: tuple = ()


PARTS = (
    PartSpec("left eye", "eye", ("3.5",)),
    PartSpec("right eye", "eye", ("3.6",)),
    PartSpec("upper teeth", "teeth", ("9.10", "9.8")),
    PartSpec("lower teeth", "teeth", ("9.11", "9.9"), riders=("tongue",)),
    PartSpec("tongue", "tongue", ("6.1", "6.2", "6.3", "6.4"), riders=("lower teeth",)),
)
#: Part name -> its :class:`PartSpec`.
PART_SPECS = {p.name: p for p in PARTS}
#: Name of the whole-head part in :func:`find_parts`'s answer.
HEAD = "head"


def _scale(face: FaceModel) -> float:
    fapu = face.fapu
    if fapu is not None and fapu.ES0 > 0:
        return float(fapu.ES0)
    ext = [np.ptp(face.world_vertices(n), axis=0).max() for n in face.meshes
           if len(face.meshes[n].vertices)]
    return float(max(ext)) / 3 if ext else 1.0


def mesh_holding(face: FaceModel, fp: str, tolerance: Optional[float] = None) -> Optional[str]:
    """The mesh a feature point lies on: its vertex tie, else the mesh with the vertex
    nearest to it (within ``tolerance``, default 5 % of ES0); None if none is near."""
    if fp not in face.points:
        return None
    tie = face.points.vertex(fp)
    if tie is not None and tie[0] in face.meshes:
        return tie[0]
    tol = 0.05 * _scale(face) if tolerance is None else tolerance
    p = face.points[fp]
    best, best_d = None, np.inf
    for name, mesh in face.meshes.items():
        if not len(mesh.vertices):
            continue
        d = float(np.min(np.linalg.norm(face.world_vertices(name) - p, axis=1)))
        if d < best_d:
            best, best_d = name, d
    return best if best_d <= tol else None


def connected_meshes(face: FaceModel, seeds: Iterable[str], exclude: Iterable[str] = (),
                     weld: float = 1e-4) -> list:
    """``seeds`` and every mesh reachable from them through shared vertex positions
    (within ``weld`` x ES0), never entering ``exclude``."""
    tol = weld * _scale(face)
    excluded = set(exclude)
    names = [n for n in face.meshes if len(face.meshes[n].vertices)]
    trees = {n: cKDTree(face.world_vertices(n)) for n in names}
    found = [s for s in seeds if s in face.meshes]
    todo = list(found)
    while todo:
        a = todo.pop()
        for b in names:
            if b in found or b in excluded:
                continue
            if trees[a].sparse_distance_matrix(trees[b], tol, output_type="coo_matrix").nnz:
                found.append(b)
                todo.append(b)
    return [n for n in face.meshes if n in found]


#: How far from spherical a mesh may be and still be an eyeball: the RMS of its vertices'
#: distances from the least-squares sphere through them, as a fraction of its radius.  A
#: sphere is 0; a cornea bulging 2.5 mm out of a 12 mm eyeball over a fifth of it stays
#: under 0.1; the reference head's other parts (teeth rows, tongue, mouth cavity, hair
#: cap) are 0.08 to 0.2, but none holds a pupil.  Too low: a modelled cornea makes an
#: eye skin, and eyeball FAPs are skipped with a warning; too high: a lid or socket piece
#: holding the pupil would be turned as an eye.
EYEBALL_ROUNDNESS = 0.1


def is_eyeball(vertices: np.ndarray, max_radius: float = np.inf) -> bool:
    """True when ``vertices`` (a component's, world coordinates) lie roughly on a
    sphere (:data:`EYEBALL_ROUNDNESS`) of radius at most ``max_radius``.

    >>> d = np.random.default_rng(0).normal(size=(200, 3))
    >>> ball = d / np.linalg.norm(d, axis=1)[:, None]
    >>> is_eyeball(ball), is_eyeball(ball * [3, 1, 1]), is_eyeball(ball, max_radius=0.5)
    (True, False, False)
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(v) < 4:
        return False
    r = np.linalg.norm(v - sphere_centre(v), axis=1)
    radius = float(r.mean())
    if not radius > 0 or radius > max_radius:
        return False
    return float(np.sqrt(np.mean((r - radius) ** 2))) <= EYEBALL_ROUNDNESS * radius


def mesh_components(triangles: np.ndarray, n_vertices: int,
                    vertices: Optional[np.ndarray] = None) -> np.ndarray:
    """(n_vertices,) label of each vertex's connected component (vertices joined by
    triangle edges; a vertex in no triangle is a component of its own, or with
    ``vertices`` given, that of a vertex in a triangle at exactly its place: a seam's
    later copy, :mod:`~mpeg4fba.cloning.seams`).

    >>> mesh_components(np.array([[0, 1, 2], [3, 4, 5], [2, 6, 0]]), 8).tolist()
    [0, 0, 0, 1, 1, 1, 0, 2]
    """
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    a = np.concatenate([t[:, 0], t[:, 1]])
    b = np.concatenate([t[:, 1], t[:, 2]])
    graph = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n_vertices, n_vertices))
    lab = connected_components(graph, directed=False)[1]
    if vertices is not None and len(t):
        used = np.zeros(n_vertices, dtype=bool)
        used[t.ravel()] = True
        if not used.all():
            _, inv = np.unique(np.asarray(vertices), axis=0, return_inverse=True)
            inv = inv.ravel()
            owner = np.full(int(inv.max()) + 1, -1)
            owner[inv[used]] = lab[used]
            loose = ~used & (owner[inv] >= 0)
            lab = lab.copy()
            lab[loose] = owner[inv[loose]]
    return lab


@dataclass
class Components:
    """A face's meshes cut into connected components, and which holds each feature point.

    ``mesh`` and ``labels``: per component, its mesh and the vertex label within that
    mesh (:func:`mesh_components`); ``holder``: point id -> component; ``distance``: point
    id -> its distance from that component's surface (0 for a vertex tie); ``skin``: the
    components holding a point of the skin (neither a part's nor inside the head,
    :data:`NOT_SURFACE`); ``parts``: part name -> its component (the one holding its
    point); ``rejected``: part name -> why its point's component is not that part;
    ``members``: part name -> all its components, of one mesh (teeth modelled one
    component per tooth; by default the one of ``parts``, :func:`match_parts` adds).
    """

    mesh: list
    labels: dict
    holder: dict
    distance: dict
    skin: set
    parts: dict
    rejected: dict
    members: dict = field(default_factory=dict)

    def __post_init__(self):
        for part, c in self.parts.items():
            self.members.setdefault(part, [c])


#: Every part's identifying points (the eyes', teeth's and tongue's).
_PART_POINTS = frozenset(fp for s in PARTS for fp in s.points)


def part_components(face: FaceModel, tolerance: Optional[float] = None) -> Components:
    """The face's components, which holds each feature point, the skin and the parts
    (see the module docstring).  A point holds to the component with the nearest
    surface, within ``tolerance`` (default 5 % of ES0); an eye's component must be an
    eyeball (:func:`is_eyeball`, radius at most half ES0) and no part's may hold a skin
    point."""
    tol = 0.05 * _scale(face) if tolerance is None else float(tolerance)
    V, T, tri_comp, offsets, labels, comp_mesh = _stacked(face)
    holder, distance, free = {}, {}, []
    for fp in face.points:
        tie = face.points.vertex(fp)
        if tie is not None and tie[0] in offsets and tie[1] < len(labels[tie[0]]):
            holder[fp], distance[fp] = comp_mesh.index(tie[0]) + int(labels[tie[0]][tie[1]]), 0.0
        else:
            free.append(fp)
    if free and len(T):
        t, _, d = closest_points(np.array([face.points[fp] for fp in free]), V, T, k=16)
        for fp, c, dist in zip(free, tri_comp[t], d):
            holder[fp], distance[fp] = int(c), float(dist)
    skin = {holder[fp] for fp in holder
            if fp not in _PART_POINTS and fp not in NOT_SURFACE and distance[fp] <= tol}
    fapu = face.fapu
    max_radius = 0.5 * float(fapu.ES0) if fapu is not None and fapu.ES0 > 0 else np.inf
    parts, rejected = {}, {}
    for spec in PARTS:
        for fp in spec.points:
            if fp not in holder or distance[fp] > tol:
                continue
            c = holder[fp]
            if c in skin:
                rejected[spec.name] = f"its point {fp} lies on the skin's mesh {comp_mesh[c]}"
            elif spec.kind == "eye" and not is_eyeball(
                    face.world_vertices(comp_mesh[c])[labels[comp_mesh[c]] == _local(comp_mesh, c)],
                    max_radius):
                rejected[spec.name] = (f"the component of {comp_mesh[c]} at its point {fp} is "
                                       "not a round eyeball")
            else:
                parts[spec.name] = c
            break
    return Components(comp_mesh, labels, holder, distance, skin, parts, rejected)


def _local(comp_mesh: list, c: int) -> int:
    """The label within its mesh of global component ``c``."""
    return c - comp_mesh.index(comp_mesh[c])


def separate_parts(face: FaceModel, components: Optional[Components] = None) -> FaceModel:
    """The face with every part that shares a mesh with something else (the skin, the
    other eye) split off into a mesh of its own, named ``<mesh>_<Part>`` (e.g.
    ``head_LeftEye``), under the same Transform; the face itself when nothing is to split
    or it has a FAT (whose vertex indices would change).  Vertex ties of the feature
    points and colours per vertex follow their vertices.

    >>> from mpeg4fba.models import reference_head
    >>> face = reference_head(resolution=0.5)
    >>> separate_parts(face) is face
    True
    """
    if len(face.fat):
        return face
    found = part_components(face) if components is None else components
    split: dict = {}                       # mesh -> [(part name, local labels)]
    for part, c in found.parts.items():
        m = found.mesh[c]
        split.setdefault(m, []).append((part, [_local(found.mesh, k) for k in
                                               found.members.get(part, [c])
                                               if found.mesh[k] == m]))
    skin_meshes = {found.mesh[c] for c in found.skin}
    # a mesh that is one part and nothing else stays whole (an eyeball with its iris
    # and cornea as components of their own)
    todo = {m: cut for m, cut in split.items() if len(cut) > 1 or m in skin_meshes}
    if not todo:
        return face
    for m, cut in todo.items():
        _enclosed_components(face, found, m, cut)
    meshes, colors, where = [], {}, {}
    taken = set(face.meshes) | set(face.transforms)
    for name, mesh in face.meshes.items():
        pieces = []
        lab = found.labels.get(name)
        if name in todo:
            rest = np.ones(len(mesh.vertices), dtype=bool)
            for part, labels in todo[name]:
                keep = np.isin(lab, labels)
                rest &= ~keep
                new = _unique_name(f"{name}_{''.join(w.capitalize() for w in part.split())}", taken)
                pieces.append((new, keep))
            if rest.any():
                pieces.insert(0, (name, rest))
        else:
            pieces = [(name, None)]
        for new, keep in pieces:
            if keep is None:
                meshes.append(mesh)
                if name in face.colors:
                    colors[name] = face.colors[name]
                continue
            index = np.full(len(mesh.vertices), -1, dtype=np.int64)
            index[keep] = np.arange(int(keep.sum()))
            tri = mesh.triangles[keep[mesh.triangles[:, 0]]]
            meshes.append(replace(mesh, name=new, vertices=mesh.vertices[keep],
                                  triangles=index[tri]))
            c = face.colors.get(name)
            if c is not None:
                c = np.asarray(c)
                colors[new] = c[keep] if c.ndim == 2 and len(c) == len(keep) else c
            where[name] = where.get(name, []) + [(new, keep, index)]
    ties = {}
    for fp, (m, v) in face.points.vertices.items():
        for new, keep, index in where.get(m, ()):
            if v < len(keep) and keep[v]:
                ties[fp] = (new, int(index[v]))
                break
        else:
            ties[fp] = (m, v)
    points = FeaturePointSet({fp: face.points[fp] for fp in face.points}, ties)
    out = FaceModel(meshes, face.transforms.values(), points=points, fapu=face.fapu,
                    fat=face.fat, name=face.name)
    out.colors = colors
    # named areas are vertex indices of meshes that may just have been renumbered
    out.regions = {}
    return out


def _enclosed_components(face: FaceModel, found: Components, mesh: str, cut: list) -> None:
    """Add to each part of ``cut`` (part name, [its component's label]) the other
    components of ``mesh`` that hold no point and lie wholly inside it: for an eye,
    inside its eyeball's sphere grown by a tenth (an iris or a cornea modelled apart,
    not the socket round it); for teeth and tongue, inside its bounding box grown by a
    tenth of its size (not a mouth cavity round the teeth)."""
    lab = found.labels[mesh]
    v = face.world_vertices(mesh)
    held = {_local(found.mesh, c) for c in set(found.holder.values()) if found.mesh[c] == mesh}
    others = np.setdiff1d(np.unique(lab), list(held))
    if not len(others):
        return
    n = int(lab.max()) + 1
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, lab, v)
    np.maximum.at(hi, lab, v)
    for part, labels in cut:
        if PART_SPECS[part].kind == "eye":
            # an eye's: wholly inside its sphere grown by a tenth (not the socket round it)
            ball = v[lab == labels[0]]
            centre = sphere_centre(ball)
            reach = 1.1 * np.linalg.norm(ball - centre, axis=1).mean()
            far = np.zeros(n)
            np.maximum.at(far, lab, np.linalg.norm(v - centre, axis=1))
            inside = others[far[others] <= reach]
        else:
            margin = 0.1 * (hi[labels[0]] - lo[labels[0]]).max()
            inside = others[(lo[others] >= lo[labels[0]] - margin).all(axis=1)
                            & (hi[others] <= hi[labels[0]] + margin).all(axis=1)]
        labels.extend(int(k) for k in inside)
        others = np.setdiff1d(others, inside)


def _unique_name(base: str, taken: set) -> str:
    name, k = base, 2
    while name in taken:
        name, k = f"{base}_{k}", k + 1
    taken.add(name)
    return name


def carry_part_points(source: FaceModel, target: FaceModel) -> dict:
    """Point id -> (mesh, vertex) of the target for the points of each part the source
    has and the target's points don't find (teeth and tongue given no points), from
    :func:`match_parts`.

    >>> from mpeg4fba.models import reference_head
    >>> face = reference_head(resolution=0.5)
    >>> carry_part_points(face, face)          # every part found by its own points
    {}
    """
    return match_parts(source, target)[1]


#: The kinds of part :func:`match_parts` matches by shape (eyes are found by their
#: pupils and their roundness, :func:`part_components`).
MATCHED_KINDS = ("teeth", "tongue")


def match_parts(source: FaceModel, target: FaceModel) -> tuple:
    """(the target's :class:`Components` with its teeth and tongue matched to the
    source's, carried points id -> (mesh, vertex)).

    Each teeth or tongue part of the source (its meshes, :func:`find_parts`) is carried
    over by the thin-plate spline that takes the source's skin points onto the target's.
    A target component belongs to it when it lies on the carried part and the carried
    part on it: the median distance both ways within 5 % of the target's ES0, so a
    mouth cavity or gums round the teeth, or the other row of clenched teeth, are not
    taken.  The part is those components (of one mesh: the one holding the target's own
    point, else the one most of the carried part lies on); they must hold no skin point,
    and cover half the carried part.  A component two parts claim goes to the one it
    lies nearer.  When the target has the part's point, its component stays in the part
    whatever the match says; when it has none, the source's points are carried over and
    put on the nearest vertices of the part.  A target without such a part (a head
    without teeth, whose mouth cavity lies further off) gets none.
    """
    src, tgt = part_components(source), part_components(target)
    V, T, tri_comp, offsets, labels, comp_mesh = _stacked(target)
    common = [k for k in source.points if k in target.points and k not in NOT_SURFACE]
    specs = [spec for spec in PARTS if spec.kind in MATCHED_KINDS and spec.name in src.parts
             and spec.name not in tgt.rejected]
    if not specs or len(common) < 5 or not len(T):
        return tgt, {}
    moving = np.array([source.points[k] for k in common])
    fixed = np.array([target.points[k] for k in common])
    tol = 0.05 * _scale(target)
    vert_comp = np.concatenate([comp_mesh.index(n) + labels[n] for n in offsets])
    source_meshes = find_parts(source)
    claims: dict = {}                       # component -> [(reverse distance, part)]
    found: dict = {}                        # part -> (members, carried points)
    for spec in specs:
        shape, tris = _part_shape(source, source_meshes.get(spec.name, []))
        ids = [fp for fp in spec.points if fp in source.points]
        if not len(tris):
            continue
        carried = feature_warp(moving, fixed, np.vstack([shape, [source.points[k] for k in ids]])
                               if ids else shape)
        shape, at = carried[:len(shape)], carried[len(shape):]
        t, _, d = closest_points(_thinned(shape), V, T, k=16)
        hit = np.where(d <= tol, tri_comp[t], -1)
        seed = tgt.parts.get(spec.name)
        others = {c for p, c in tgt.parts.items() if p != spec.name} | tgt.skin
        cands = [int(c) for c in np.unique(hit[hit >= 0]) if c not in others]
        if not cands:
            continue
        mesh = comp_mesh[seed] if seed is not None else \
            max({comp_mesh[c] for c in cands}, key=lambda m: np.isin(
                hit, [c for c in cands if comp_mesh[c] == m]).sum())
        members = {}
        for c in cands:
            if comp_mesh[c] != mesh:
                continue
            back = float(np.median(closest_points(_thinned(V[vert_comp == c]), shape, tris,
                                                  k=16)[2]))
            if back <= tol:
                members[c] = back
        if seed is None and np.isin(hit, list(members)).sum() < len(hit) / 2:
            continue
        for c, back in members.items():
            claims.setdefault(c, []).append((back, spec.name))
        found[spec.name] = (members, seed, ids, at)
    points, out = dict(tgt.parts), {p: list(m) for p, m in tgt.members.items()}
    carried_ids: dict = {}
    names, firsts = list(offsets), np.array(list(offsets.values()))
    for part, (members, seed, ids, at) in found.items():
        mine = [c for c in members if min(claims[c])[1] == part and c not in
                {s for p, s in tgt.parts.items() if p != part}]
        if seed is not None:
            out[part] = sorted(set(mine) | {seed})
            continue
        if not mine:
            continue
        own = np.flatnonzero(np.isin(tri_comp, mine))
        tri, bary, _ = closest_points(at, V, T[own], k=16)
        rows = T[own][tri, np.argmax(bary, axis=1)]
        for fp, row in zip(ids, rows):
            m = names[int(np.searchsorted(firsts, row, side="right")) - 1]
            carried_ids[fp] = (m, int(row - offsets[m]))
        points[part] = int(vert_comp[rows[0]])
        out[part] = sorted(mine)
    return Components(tgt.mesh, tgt.labels, tgt.holder, tgt.distance, tgt.skin, points,
                      tgt.rejected, out), carried_ids


def _part_shape(face: FaceModel, meshes: list) -> tuple:
    """(world vertices, triangles) of ``meshes`` stacked."""
    verts, tris, first = [], [], 0
    for n in meshes:
        verts.append(face.world_vertices(n))
        tris.append(face.meshes[n].triangles + first)
        first += len(face.meshes[n].vertices)
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.vstack(verts), np.vstack(tris)


def _thinned(points: np.ndarray, most: int = 256) -> np.ndarray:
    """At most about ``most`` of ``points``, evenly taken."""
    return points[:: max(1, len(points) // most)]


def _stacked(face: FaceModel) -> tuple:
    """(world vertices, triangles, component of each triangle, first row of each mesh,
    mesh name -> vertex labels within it, mesh of each component) of every mesh with
    vertices, stacked; components numbered mesh by mesh (:func:`mesh_components`)."""
    verts, tris, tri_comp, offsets, labels, comp_mesh, first = [], [], [], {}, {}, [], 0
    for n, m in face.meshes.items():
        if not len(m.vertices):
            continue
        lab = mesh_components(m.triangles, len(m.vertices), m.vertices)
        labels[n] = lab
        offsets[n] = first
        verts.append(face.world_vertices(n))
        tris.append(m.triangles + first)
        tri_comp.append(len(comp_mesh) + lab[m.triangles[:, 0]])
        comp_mesh.extend([n] * (int(lab.max()) + 1))
        first += len(m.vertices)
    if not verts:
        return (np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64),
                {}, {}, [])
    return (np.vstack(verts), np.vstack(tris), np.concatenate(tri_comp), offsets, labels,
            comp_mesh)


def find_parts(face: FaceModel, reasons: Optional[dict] = None) -> dict:
    """Part name -> list of mesh names, for each part of :data:`PARTS` found, and
    :data:`HEAD` -> every mesh.  A part is found on a mesh of its own (after
    :func:`separate_parts`): a mesh that also holds a skin point, or an eye's that is not
    round, is no part, and ``reasons`` (a dict, when given) gets part name -> why."""
    found = part_components(face)
    if reasons is not None:
        reasons.update(found.rejected)
    holders = {}
    for part, c in found.parts.items():
        m = found.mesh[c]
        if len(np.unique(found.labels[m])) > 1 and any(
                found.mesh[o] == m for o in found.skin):
            if reasons is not None:
                reasons[part] = (f"it shares the mesh {m} with the skin "
                                 "(separate_parts splits it off)")
            continue
        holders[part] = m
    # meshes holding a feature point that belongs to no part: the skin (and hair...)
    skin = {found.mesh[c] for c in found.skin}
    out = {}
    for name, seed in holders.items():
        others = {m for n, m in holders.items() if n != name} | skin
        others.discard(seed)
        out[name] = connected_meshes(face, [seed], exclude=others)
    out[HEAD] = list(face.meshes)
    return out
