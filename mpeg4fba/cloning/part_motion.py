"""The motion of the eyes, teeth, tongue and head: carried from the source's Transforms
(and part meshes) to the target's.

Pandzic's Facial Motion Cloning, "Treating eyes, teeth, tongue and global motion": the
Transform that carries each part's motion in the source is found
(:func:`~mpeg4fba.cloning.part_transforms.source_transform`), the target's Transform for the same
part too (:func:`~mpeg4fba.cloning.part_transforms.target_transform`), the centres of rotation of
the eyes and the head checked and new ones installed where wrong
(:class:`TransformInstaller`), and the rotations and translations mapped over
(:meth:`PartMapping.transform_entries`).  Where we go beyond the paper:

* a target with no Transform for a part gets one installed (the paper ignores the
  motion, with a warning), and a jaw's pivot is only moved when far off;
* translations are rescaled by the part's FAPU factors, like the skin's motion
  (``scale_motion``);
* motion of the part *meshes* (FaceDefMesh entries, a source animated by morph targets)
  is fitted with a rigid motion (:func:`~mpeg4fba.cloning.rigid.fit_rigid`) and carried
  over as Transform entries when it is rigid, and otherwise (a pupil dilating, a tongue
  curling: the paper's tongue "would obviously require it to be flexible") mapped
  vertex to vertex in 3D by inverse distance over the 4 nearest source vertices
  (:meth:`PartMapping.mesh_entries`).

>>> from mpeg4fba.models import reference_head
>>> face = reference_head(resolution=0.5)
>>> installer = TransformInstaller(face.copy(), {"head": list(face.meshes)},
...                                head_centre=face.points["7.1"], head_moves=False,
...                                tolerance=0.02 * float(face.fapu.ES0))
>>> installer.transform("head", np.asarray(face.points["7.1"], float))
'Head'
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..fba.face import FaceModel, FaceTransform
from ..fba.fat import FaceDefTable, FaceDefTransform, interval_weights
from .part_transforms import lowest_common_transform, target_transform
from .parts import HEAD, PART_SPECS
from .rigid import axis_angle, fit_rigid, rotation_centre, sphere_centre
from .skin import Skin, linear_part, stack_meshes
from .transfer import mesh_entries

__all__ = ["TransformInstaller", "PartMapping", "PART_ICP_ITERATIONS", "similarity"]

#: Rounds of the similarity ICP laying a rigid source part (jaw, tongue) on the target's.
PART_ICP_ITERATIONS = 10


class Similarity(NamedTuple):
    """``x -> scale * rotation @ x + translation``."""
    scale: float
    rotation: np.ndarray
    translation: np.ndarray

    def apply(self, x: np.ndarray) -> np.ndarray:
        return self.scale * np.asarray(x, float) @ self.rotation.T + self.translation


def similarity(x: np.ndarray, y: np.ndarray) -> Similarity:
    """The least-squares similarity (Umeyama) taking points ``x`` (n, 3) to ``y``.

    >>> x = np.random.default_rng(0).normal(size=(10, 3))
    >>> s = similarity(x, 2 * x + 1)
    >>> round(s.scale, 6), bool(np.allclose(s.apply(x), 2 * x + 1))
    (2.0, True)
    """
    x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
    y = np.asarray(y, dtype=np.float64).reshape(-1, 3)
    cx, cy = x.mean(axis=0), y.mean(axis=0)
    X, Y = x - cx, y - cy
    U, S, Vt = np.linalg.svd(Y.T @ X / len(x))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
    R = U @ D @ Vt
    var = float((X ** 2).sum() / len(x))
    scale = float(np.trace(np.diag(S) @ D) / var) if var > 0 else 1.0
    return Similarity(scale, R, cy - scale * R @ cx)


class TransformInstaller:
    """The target's part Transforms on the face being built (``face``): found, or
    installed on first use, centres checked.

    ``parts`` is the target's :func:`~mpeg4fba.cloning.parts.find_parts`; ``head_centre``
    where the head turns (7.1); ``head_moves`` whether the source moves its head's
    Transform (then the head's Transform is installed before any other part's, so the
    others hang under it); ``tolerance`` how far an eye's or the head's pivot may be
    from its centre (25 times that for a jaw).  ``notes`` collects what was installed
    or moved (one :class:`~mpeg4fba.cloning.errors.CloneWarning` each), ``skipped`` the
    tables moving a part the target lacks.
    """

    def __init__(self, face: FaceModel, parts: dict, *, head_centre: np.ndarray,
                 head_moves: bool, tolerance: float):
        self.face = face
        self.parts = {p: list(m) for p, m in parts.items()}
        self.head_centre = head_centre
        self.head_moves = head_moves
        self.chosen: dict = {}
        self.notes: list = []
        #: part name -> tables (fap, select) whose motion of it the target can't take
        self.skipped: dict = {}
        self._tol = tolerance

    def note(self, message: str) -> None:
        if message not in self.notes:
            self.notes.append(message)

    def skip(self, part: str, table: FaceDefTable) -> None:
        """Record that ``table`` moves ``part``, which the target lacks (one warning per
        kind of part at the end, :meth:`~mpeg4fba.cloning.fmc.FacialMotionCloner.clone`)."""
        self.skipped.setdefault(part, set()).add((table.fap, table.select))

    def transform(self, part: str, centre: Optional[np.ndarray]) -> str:
        """The name of the target Transform that carries ``part``, turning about
        ``centre`` (None: any)."""
        if part in self.chosen:
            return self.chosen[part]
        if part != HEAD and HEAD not in self.chosen and self.head_moves:
            self.transform(HEAD, np.asarray(self.head_centre, float))
        face = self.face
        name = target_transform(face, part, self.parts)
        if name is None:
            name = self._install(part, centre)
        elif centre is not None:
            # eyes and head must turn about their centres; a jaw's pivot is the
            # modeller's choice unless it is far off (e.g. left at the origin)
            rigid = part == HEAD or PART_SPECS[part].kind == "eye"
            name = self._check_centre(part, name, centre, self._tol if rigid else 25 * self._tol)
        self.chosen[part] = name
        for rider in (PART_SPECS[part].riders if part in PART_SPECS else ()):
            if rider in self.parts and target_transform(face, rider, self.parts) == name:
                self.chosen.setdefault(rider, name)
        return name

    def _unique(self, base: str) -> str:
        taken = set(self.face.transforms) | set(self.face.meshes)
        name, k = base, 2
        while name in taken:
            name, k = f"{base}_{k}", k + 1
        return name

    def _install(self, part: str, centre: Optional[np.ndarray]) -> str:
        face = self.face
        meshes = self.parts[part]
        parent = lowest_common_transform(face, meshes)
        label = "".join(w.capitalize() for w in part.split())
        name = self._unique(label if part == HEAD else f"{label}Motion")
        M = face.world_matrix(parent)[0]
        c = np.zeros(3) if centre is None else np.linalg.inv(M) @ np.append(centre, 1.0)
        face.transforms[name] = FaceTransform(name, parent=parent, center=tuple(c[:3]))
        if part == HEAD:
            for t in list(face.transforms.values()):
                if t.name != name and t.parent is None:
                    t.parent = name
            for m in face.meshes.values():
                if m.parent is None:
                    m.parent = name
        else:
            for mname in meshes:
                self._reparent(mname, name, parent)
        self.note(f"installed Transform {name} for the {part} of the target"
                  + (f", turning about {np.round(centre, 6).tolist()}" if centre is not None else ""))
        return name

    def _reparent(self, mesh: str, new_parent: str, common: Optional[str]) -> None:
        face = self.face
        m = face.meshes[mesh]
        if m.parent != common:
            # bake the transforms between the common ancestor and the mesh into its vertices
            A = np.linalg.inv(face.world_matrix(common)[0]) @ face.world_matrix(m.parent)[0]
            m.vertices = m.vertices @ A[:3, :3].T + A[:3, 3]
        m.parent = new_parent
        face.invalidate()

    def _check_centre(self, part: str, name: str, centre: np.ndarray, tol: float) -> str:
        face = self.face
        t = face.transforms[name]
        M = face.world_matrix(t.parent)[0]
        pivot = M[:3, :3] @ (np.asarray(t.translation, float) + np.asarray(t.center, float)) + M[:3, 3]
        if np.linalg.norm(pivot - centre) <= tol:
            return name
        local = np.linalg.inv(M) @ np.append(centre, 1.0)
        still = np.allclose(t.rotation[3] % (2 * np.pi), 0) and np.allclose(t.scale, 1)
        if still:
            t.center = tuple(local[:3] - np.asarray(t.translation, float))
            self.note(f"moved the centre of Transform {name} ({part}) to "
                      f"{np.round(centre, 6).tolist()}")
            return name
        # a turned or scaled Transform: a new pivot Transform under it takes its children
        W = face.world_matrix(name)[0]
        c = np.linalg.inv(W) @ np.append(centre, 1.0)
        pivot_name = self._unique(f"{name}Pivot")
        face.transforms[pivot_name] = FaceTransform(pivot_name, parent=name, center=tuple(c[:3]))
        for other in face.transforms.values():
            if other.parent == name and other.name != pivot_name:
                other.parent = pivot_name
        for m in face.meshes.values():
            if m.parent == name:
                m.parent = pivot_name
        face.invalidate()
        self.note(f"installed Transform {pivot_name} under {name} ({part}) to turn about "
                  f"{np.round(centre, 6).tolist()}")
        return pivot_name


class PartMapping:
    """How the source's part motion becomes the target's, for one pair of faces.

    ``source``, ``target``: the two skins (their faces carry the parts); ``source_parts``
    and ``target_parts`` from :func:`~mpeg4fba.cloning.parts.find_parts`;
    ``source_transforms`` part -> the source Transform carrying its motion (None: its
    meshes move alone); ``scale_motion``, ``rigid_tolerance`` and ``min_motion`` as the
    cloner's.  The vertex-to-vertex maps of non-rigid parts are built on first use and
    kept.
    """

    def __init__(self, source: Skin, target: Skin, source_parts: dict, target_parts: dict,
                 source_transforms: dict, *, scale_motion: bool = True,
                 rigid_tolerance: float = 0.05, min_motion: float = 1e-3):
        self.src, self.tgt = source, target
        self.source, self.target = source.face, target.face
        self.source_parts, self.target_parts = source_parts, target_parts
        self.source_transforms = source_transforms
        self.scale_motion = scale_motion
        self.rigid_tolerance = rigid_tolerance
        self.min_motion = min_motion
        self._maps: dict = {}

    def installer(self, face: FaceModel) -> TransformInstaller:
        """A :class:`TransformInstaller` for ``face``, the target being built."""
        ts = self.source_transforms[HEAD]
        head_moves = ts is not None and any(e.transform == ts for t in self.source.fat
                                            for e in t.transforms)
        return TransformInstaller(face, self.target_parts,
                                  head_centre=self.target.points["7.1"], head_moves=head_moves,
                                  tolerance=0.02 * float(self.target.fapu.ES0))

    def transform_entries(self, table: FaceDefTable, borders: np.ndarray,
                          inst: TransformInstaller) -> list:
        """Target FaceDefTransforms for the source's part Transforms this table drives."""
        out, seen = [], set()
        for part, meshes in self.source_parts.items():
            ts = self.source_transforms[part]
            entries = [e for e in table.transforms if e.transform == ts]
            if ts is None or not entries:
                continue
            if part != HEAD and ts == self.source_transforms[HEAD]:
                continue  # the head's transform moves this part; it is mapped as the head's
            if part not in self.target_parts:
                inst.skip(part, table)
                continue
            pivot = self._source_pivot(ts)
            tt = inst.transform(part, self._target_centre(part, pivot))
            R_s = linear_part(self.source, self.source.transforms[ts].parent)
            R_t = linear_part(inst.face, inst.face.transforms[tt].parent)
            for e in entries:
                if e.field == "rotation":
                    axis = R_t.T @ (R_s @ np.asarray(e.rotation[:3], float))
                    new = FaceDefTransform(tt, "rotation", rotation=(*axis, e.rotation[3]))
                elif e.field == "translation":
                    t = self._map_translation(part, R_s @ np.asarray(e.translation, float))
                    new = FaceDefTransform(tt, "translation", translation=tuple(R_t.T @ t))
                else:
                    new = FaceDefTransform(tt, "scale", scale=e.scale)
                key = (tt, new.field, new.rotation, new.translation, new.scale)
                if key not in seen:
                    seen.add(key)
                    out.append(new)
        return out

    def mesh_entries(self, table: FaceDefTable, borders: np.ndarray, out: FaceModel,
                     inst: TransformInstaller) -> tuple:
        """(FaceDefMesh entries, FaceDefTransform entries) for the motion of the source's
        part meshes in ``table``: a rigid motion becomes Transform entries, anything
        else is mapped vertex to vertex onto ``out``'s part meshes."""
        meshes_out, transforms_out = [], []
        nz = borders[borders != 0]
        for part, meshes in self.source_parts.items():
            if part == HEAD:
                continue
            entries = [m for m in table.meshes if m.mesh in meshes]
            if not entries:
                continue
            if part not in self.target_parts:
                inst.skip(part, table)
                continue
            x, offsets = stack_meshes(self.source, meshes)
            motion = np.zeros((len(x), len(nz), 3))
            for m in entries:
                first, _ = offsets[m.mesh]
                R = linear_part(self.source, self.source.meshes[m.mesh].parent)
                w = interval_weights(m.borders, nz)
                motion[first + m.indices] += np.einsum("bj,kjc->kbc", w, m.displacements) @ R.T
            size = float(np.ptp(x, axis=0).max()) or 1.0
            fits = [fit_rigid(x, x + motion[:, j]) for j in range(len(nz))]
            rigid = all(f.is_rigid(self.rigid_tolerance, 1e-9 * size) for f in fits) and \
                all(f.residual <= self.rigid_tolerance * size for f in fits)
            if rigid and len(nz) and PART_SPECS[part].kind != "eye":
                transforms_out.extend(self._refitted_entries(part, nz, motion, inst))
            elif rigid and len(nz):
                transforms_out.extend(self._rigid_entries(part, x, nz, fits, inst))
            else:
                meshes_out += self._deformation(part, borders, motion, out)
        return meshes_out, transforms_out

    def _source_pivot(self, transform: str) -> np.ndarray:
        t = self.source.transforms[transform]
        M = self.source.world_matrix(t.parent)[0]
        return M[:3, :3] @ (np.asarray(t.translation, float) + np.asarray(t.center, float)) + M[:3, 3]

    def _target_centre(self, part: str, source_pivot: np.ndarray) -> np.ndarray:
        """Where the target's part must turn about: an eye's centre, 7.1 for the head,
        the source's pivot carried over for teeth and tongue."""
        if part == HEAD:
            return np.asarray(self.target.points["7.1"], float)
        if PART_SPECS[part].kind == "eye":
            return sphere_centre(np.vstack([self.target.world_vertices(m)
                                            for m in self.target_parts[part]]))
        return self.src.space.map_point(source_pivot, self.tgt.space)

    def _anchor(self, part: str) -> Optional[str]:
        pts = PART_SPECS[part].points if part in PART_SPECS else ("7.1",)
        for fp in pts:
            if fp in self.source.points and fp in self.target.points:
                return fp
        return None

    def _map_translation(self, part: str, t_world: np.ndarray) -> np.ndarray:
        if not self.scale_motion:
            return t_world
        fp = self._anchor(part)
        if fp is None:
            return t_world
        fs = self.src.space.normaliser.factors(self.source.points[fp][None])[0]
        ft = self.tgt.space.normaliser.factors(self.target.points[fp][None])[0]
        return t_world / fs * ft

    def _rigid_entries(self, part, x, nz, fits, inst) -> list:
        j = int(np.argmax(np.abs(nz)))
        value, fit = float(nz[j]), fits[j]
        axis, angle = axis_angle(fit.rotation)
        if PART_SPECS[part].kind == "eye":
            pivot = sphere_centre(x)
        else:
            pivot = rotation_centre(fit, x.mean(axis=0))
        slide = fit.translation - (np.eye(3) - fit.rotation) @ pivot
        tt = inst.transform(part, self._target_centre(part, pivot) if angle > 1e-9 else None)
        moved = np.linalg.norm(slide) > 1e-9 * (np.ptp(x, axis=0).max() or 1.0)
        return _entries(inst, tt, axis, angle, value,
                        self._map_translation(part, slide) if moved else None)

    def _refitted_entries(self, part: str, nz: np.ndarray, motion: np.ndarray,
                          inst: TransformInstaller) -> list:
        """Transform entries for the rigid motion of a jaw or tongue: the source's vertex
        motion carried to the target's part (:meth:`_mapped`) and a rigid motion fitted
        there.  The FAPs that move them (open_jaw, thrust_jaw, the tongue's) are
        displacements in FAPUs, not angles: on a longer jaw the same opening is a smaller
        turn.  Copying the source's angle put ICT's lower teeth up to 5.9 degrees off the
        truth on random identity pairs (``benchmarks/bench_clone_pairs.py``)."""
        j = int(np.argmax(np.abs(nz)))
        value = float(nz[j])
        xt, _ = stack_meshes(self.target, self.target_parts[part])
        fit = fit_rigid(xt, xt + self._rigid_mapped(part, motion[:, j]))
        axis, angle = axis_angle(fit.rotation)
        pivot = rotation_centre(fit, xt.mean(axis=0))
        slide = fit.translation - (np.eye(3) - fit.rotation) @ pivot
        tt = inst.transform(part, pivot if angle > 1e-9 else None)
        moved = np.linalg.norm(slide) > 1e-9 * (np.ptp(xt, axis=0).max() or 1.0)
        return _entries(inst, tt, axis, angle, value, slide if moved else None)

    def _rigid_mapped(self, part: str, motion: np.ndarray) -> np.ndarray:
        """(n_target, 3) a rigid part's source vertex motion (n_source, 3) on the target's
        part: the source part laid on the target's by a similarity ICP (started from the
        global normalisation, :data:`PART_ICP_ITERATIONS` rounds), each target vertex
        taking the motion of its nearest laid source vertices (inverse distance, 4).
        A jaw or tongue is one solid, so fitting it whole is more faithful than the
        per-region normalisation, whose offsets grow away from the anchor point (a jaw's
        hinge came out up to 19 % of the eye distance off on ICT pairs); the motion is
        then scaled like a translation (:meth:`_map_translation`)."""
        xs, _ = stack_meshes(self.source, self.source_parts[part])
        xt, _ = stack_meshes(self.target, self.target_parts[part])
        laid = self.src.space.map_point_array(xs, self.tgt.space)
        tree = cKDTree(xt)
        for _ in range(PART_ICP_ITERATIONS):
            _, k = tree.query(laid)
            laid = similarity(laid, xt[k]).apply(laid)
        n = min(4, len(laid))
        dist, idx = cKDTree(laid).query(xt, k=n)
        dist, idx = dist.reshape(len(xt), n), idx.reshape(len(xt), n)
        w = 1.0 / np.maximum(dist, 1e-12)
        w /= w.sum(axis=1, keepdims=True)
        d = np.einsum("ik,ikc->ic", w, motion[idx])
        if self.scale_motion:
            fp = self._anchor(part)
            if fp is not None:
                d = d / self.src.space.normaliser.factors(self.source.points[fp][None])[0] \
                    * self.tgt.space.normaliser.factors(self.target.points[fp][None])[0]
        return d

    def _mapped(self, part: str, motion: np.ndarray) -> np.ndarray:
        """(n_target, k, 3) the source part's vertex motion (n_source, k, 3) on the
        target's part vertices, scaled by the FAPU factors with ``scale_motion``."""
        w, _ = self._part_map(part)
        k = motion.shape[1]
        s = motion.reshape(len(motion), 3 * k)
        xs, _ = stack_meshes(self.source, self.source_parts[part])
        xt, _ = stack_meshes(self.target, self.target_parts[part])
        if self.scale_motion:
            s = s / np.tile(self.src.space.normaliser.factors(xs), (1, k))
        d = np.asarray(w @ s)
        if self.scale_motion:
            d = d * np.tile(self.tgt.space.normaliser.factors(xt), (1, k))
        return d.reshape(len(d), k, 3)

    def _deformation(self, part: str, borders: np.ndarray, motion: np.ndarray,
                     out: FaceModel) -> list:
        """Non-rigid motion of a part mapped to the target's part meshes by 3D proximity."""
        _, t_offsets = self._part_map(part)
        return mesh_entries(out, t_offsets, borders, self._mapped(part, motion), self.min_motion)

    def _part_map(self, part: str) -> tuple:
        if part not in self._maps:
            xs, _ = stack_meshes(self.source, self.source_parts[part])
            xt, offsets = stack_meshes(self.target, self.target_parts[part])
            ps = self.src.space.normalise(xs)
            pt = self.tgt.space.normalise(xt)
            fp = self._anchor(part)
            if fp is not None:
                pt = pt + (self.src.space.normalise(self.source.points[fp][None])
                           - self.tgt.space.normalise(self.target.points[fp][None]))
            k = min(4, len(ps))
            dist, idx = cKDTree(ps).query(pt, k=k)
            dist, idx = dist.reshape(len(pt), k), idx.reshape(len(pt), k)
            inv = 1.0 / np.maximum(dist, 1e-12)
            inv[dist <= 1e-12] = 1e12
            inv /= inv.sum(axis=1, keepdims=True)
            w = sp.csr_matrix((inv.ravel(), (np.repeat(np.arange(len(pt)), k), idx.ravel())),
                              shape=(len(pt), len(ps)))
            self._maps[part] = (w, offsets)
        return self._maps[part]


def _entries(inst: TransformInstaller, tt: str, axis: np.ndarray, angle: float, value: float,
             translation: Optional[np.ndarray]) -> list:
    """The FaceDefTransform entries of Transform ``tt`` for a rotation (``axis``, ``angle``,
    world frame; none below 1e-9 rad) and a ``translation`` (world; None: none) reached at
    FAP value ``value``, in the frame of ``tt``'s parent."""
    R_t = linear_part(inst.face, inst.face.transforms[tt].parent)
    entries = []
    if angle > 1e-9:
        entries.append(FaceDefTransform(tt, "rotation", rotation=(*(R_t.T @ axis), angle / value)))
    if translation is not None:
        entries.append(FaceDefTransform(tt, "translation",
                                        translation=tuple(R_t.T @ (translation / value))))
    return entries
