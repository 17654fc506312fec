"""Facial Motion Cloning (Pandzic): copy every FAP, viseme and expression of a source
face onto a target face, as a FAT.

The cloner (:class:`FacialMotionCloner`) runs the paper's steps in this order, each a
public function of its own module:

0. Before any work (:mod:`~mpeg4fba.cloning.points`, :mod:`~mpeg4fba.cloning.checks`,
   :mod:`~mpeg4fba.cloning.parts`): the required points (:data:`REQUIRED_POINTS`; the
   rest of what :func:`mpeg4fba.fba.requirements.required_points` asks for is put by
   the cloning), the points on the meshes in the meshes' units; teeth and tongue points
   the target lacks carried over from the source, and parts welded into another mesh
   split off.
1. Both faces' skin (every mesh that is not an eye, teeth or tongue) is stacked, normalised
   and projected (:class:`~mpeg4fba.cloning.skin.Skin`; the paper's "Normalizing the
   face").
2. The correspondence (:func:`~mpeg4fba.cloning.correspondence.correspond`; "Aligning
   source and target face"): the target aligned on the source by its feature points in
   2D, then, by default, placed on the source's surface in 3D (:data:`ALIGNMENTS`).
3. The lip and eyelid regions of both (:func:`~mpeg4fba.cloning.weights.slit_labels`,
   :mod:`~mpeg4fba.cloning.lips`; "Treating the lip region").
4. The mapping, built once (:func:`~mpeg4fba.cloning.weights.mapping_weights`; "Mapping
   facial motion", "Antialiasing"): for every target skin vertex, anti-aliased weights
   over the source skin vertices, one sparse matrix ``W``.

:meth:`FacialMotionCloner.clone` then makes the target's FAT:

5. Every motion of the source (each table at each of its interval borders,
   :func:`~mpeg4fba.cloning.transfer.source_skin_motion`) is scaled into the target's
   units (:func:`~mpeg4fba.cloning.transfer.motion_scale`; ``scale_motion=False`` skips
   it, a pure mapping), all at once as one sparse matrix ``S``; the target's motions are
   ``W @ S`` (:meth:`FacialMotionCloner.map_skin`; "Computing facial motion").
6. The eyes, teeth, tongue and head (:class:`~mpeg4fba.cloning.part_motion.PartMapping`;
   "Treating eyes, teeth, tongue and global motion"): motion of the Transform that
   carries them in the source is carried over to the target's Transform for the same
   part (found, or installed when the target has none or its centre of rotation is
   wrong, :class:`~mpeg4fba.cloning.part_motion.TransformInstaller`); motion of their
   meshes is fitted with a rigid motion and carried over the same way, or, when it is
   not rigid (a pupil dilating, a tongue curling), mapped vertex to vertex in 3D.
7. Each target table gets the source's interval borders: the target's displacement at
   each border, differenced, gives the per-interval displacements of FaceDefMesh
   (:func:`~mpeg4fba.cloning.transfer.mesh_entries`).  Tables that move nothing on the
   target (the eyeball FAPs of a head without eyeballs) are left out, with one warning
   per missing part; skin points the target lacks and its FAPs need (the ears') are put
   where the mapping places the source's (:meth:`FacialMotionCloner.derive_points`).

Example
-------
>>> from mpeg4fba.models import reference_head
>>> source = reference_head(resolution=0.5)
>>> target = reference_head(resolution=0.5, face_width=1.1, jaw=0.9, seed=3)
>>> target.fat = FAT()
>>> cloned = FacialMotionCloner(source, target).clone()
>>> len(cloned.fat.faps), len(cloned.fat.visemes), len(cloned.fat.expressions)
(66, 14, 6)

References
----------
I. S. Pandzic, "Facial Motion Cloning", Graphical Models 65(6), 2003.
"""
from __future__ import annotations

import warnings
from functools import cached_property
from typing import Callable, Optional, Sequence, Union

import numpy as np
import scipy.sparse as sp

from ..fba.face import FaceModel
from ..fba.fat import FAT, FaceDefTable, table_borders
from ..fba.featurepoints import FeaturePointSet, point_order
from ..fba.requirements import fap_points, required_points
from .checks import check_placement
from .detect import FaceNotFoundError, find_feature_points
from .correspondence import (ALIGNMENTS, DERIVE_DISTANCE, NECK_RATIO,
                             AlignOptions, Correspondence, correspond, derive_points)
from .errors import CloneWarning, check_choice
from .lips import LIPS, SIDE_BLEND, SLITS
from .part_motion import PartMapping
from .part_transforms import source_transform
from .parts import PART_SPECS, find_parts, match_parts, separate_parts
from .points import REQUIRED_POINTS, check_faces, required_points_missing
from .projection import MOUTH_ANGLE
from .seams import weld_seams
from .skin import Skin
from .registration import REGISTRATION_MEMBRANE
from .transfer import map_skin, mesh_entries, motion_scale, source_skin_motion
from .weights import (FACING, FACING_RESOLUTION, INTERPOLATIONS, OUTSIDE_RULES, OVERLAP_RULES,
                      WeightOptions, mapping_weights, slit_labels, visible_triangles)

__all__ = ["FacialMotionCloner", "PreparedSource", "CloneWarning", "required_points_missing",
           "OVERLAP_RULES", "OUTSIDE_RULES", "ALIGNMENTS", "NECK_RATIO",
           "INTERPOLATIONS", "FACING", "FACING_RESOLUTION",
           "DERIVE_DISTANCE", "visible_triangles"]


class PreparedSource:
    """The source's side of the cloning, worked out once and shared by any number of
    targets (a batch sends it to each worker once): the source's placement checked,
    its parts split off and found, its skin stacked in the normalised and alignment
    spaces, every table's skin motion as one sparse matrix, and (on first use) the
    feature points the detector finds on it, which put a target's found points into
    the source's convention (:func:`~mpeg4fba.cloning.autopoints.matched_points`).

    Cloning onto a target from a PreparedSource gives exactly what cloning from the
    face itself gives.

    Parameters
    ----------
    source : FaceModel
        The face whose FAT is cloned, with the :data:`REQUIRED_POINTS`.
    positions, mouth_angle
        The cloner's options of the same names (the skin's spaces depend on them).
    placement : bool
        Check the source's points lie on its meshes, in their units, first.

    Attributes
    ----------
    face, separated : FaceModel
        The source as given, and with its parts split off (the mapping's source).
    parts, transforms : dict
        :func:`~mpeg4fba.cloning.parts.find_parts`, and the Transform carrying each part.
    skin : Skin
        The stacked skin in the normalised and alignment spaces.
    motion, found
        On first use (:meth:`warm` works them out at once): see below.

    >>> from mpeg4fba.models import reference_head
    >>> source = PreparedSource(reference_head(resolution=0.5))
    >>> len(source.motion[0]) == len(source.face.fat)
    True
    """

    def __init__(self, source: FaceModel, *, positions: str = "global",
                 mouth_angle: float = MOUTH_ANGLE, placement: bool = True):
        if placement:
            check_placement(source, "source")
        self.face = source
        self.positions, self.mouth_angle = positions, mouth_angle
        #: the source with its parts split off (the mapping's source), its seams joined
        #: (:mod:`~mpeg4fba.cloning.seams`)
        self.separated = separate_parts(weld_seams(source).face)
        self.parts = find_parts(self.separated)
        #: the Transform carrying each part's motion (None: its meshes move alone)
        self.transforms = {p: source_transform(self.separated, m) for p, m in self.parts.items()}
        self.skin = Skin(self.separated, self.parts, positions, mouth_angle)
        _check_skin(self.skin, "source")

    @cached_property
    def motion(self) -> tuple:
        """(tables sorted by key, each one's interval borders, the (Ns, 3K) sparse skin
        motion of all of them at their borders), :meth:`FacialMotionCloner.clone`'s step 5."""
        tables = sorted(self.separated.fat, key=lambda t: t.key)
        borders = [table_borders(t) for t in tables]
        columns = source_skin_motion(self.skin, set(self.transforms.values()), tables, borders)
        return tables, borders, columns

    @cached_property
    def found(self):
        """The feature points :func:`~mpeg4fba.cloning.detect.find_feature_points` finds
        on the source, or the :class:`~mpeg4fba.cloning.detect.FaceNotFoundError` saying
        why none were (kept, not raised: the found points are then used as found)."""
        try:
            return find_feature_points(self.face)
        except FaceNotFoundError as e:
            return e

    def warm(self, detect: bool = True) -> "PreparedSource":
        """Work out everything now (before it is sent to workers); ``detect``: the
        source's found points too."""
        self.motion
        self.skin.normalised
        if detect:
            self.found
        return self


def _check_skin(skin: Skin, which: str) -> None:
    if not len(skin.vertices):
        raise ValueError(f"the {which} face ({skin.face.name}) has no skin: all its meshes "
                         "were taken for eyes, teeth or tongue, by the feature points "
                         "3.5, 3.6, 9.8-9.11 and 6.1-6.4 they hold")


class FacialMotionCloner:
    """The target-to-source mapping of two faces, built once; :meth:`clone` then makes
    the target's FAT and :meth:`map_skin` maps any set of source skin motions.

    Parameters
    ----------
    source, target : FaceModel
        Both with the :data:`REQUIRED_POINTS`; the source's FAT is cloned.  The source
        may be a :class:`PreparedSource`, its side worked out once for many targets.
    support : float
        Radius of the anti-aliasing filter (alignment space; normalised space with the
        surface interpolation), 0 to turn it off.
    samples : int
        Points on the filter's circle.
    scale_motion : bool
        Normalise motion by the regional FAPU factors, the paper's method
        (:func:`~mpeg4fba.cloning.transfer.motion_scale`); False copies it as is.
    positions : str
        "global" (default) or "regional" (:mod:`~mpeg4fba.cloning.alignment`); with a
        :class:`PreparedSource`, the one it was prepared with.
    triangulation : str or id triples
        "fixed", "delaunay" or id triples (:func:`~mpeg4fba.cloning.alignment.align`).
    lips, eyelids : bool
        Treat the lip regions, and the eyelids the same way (:mod:`~mpeg4fba.cloning.lips`).
    mouth_angle : float
        The mouth's angular width in the cylindrical projection
        (default :data:`~mpeg4fba.cloning.projection.MOUTH_ANGLE`; with a
        :class:`PreparedSource`, the one it was prepared with).
    rigid_tolerance : float
        How far a part's mesh motion may be from rigid, as a fraction of its size, to
        become a Transform motion.
    min_motion : float
        Target vertices moving less than this fraction of a table's largest motion are
        left out of it.
    outside, overlap : str
        :data:`OUTSIDE_RULES`, :data:`OVERLAP_RULES` (2D interpolation).
    by_mesh : bool
        Map meshes to their counterparts (:func:`~mpeg4fba.cloning.skin.mesh_groups`);
        False: every target skin mesh from all the source's, the paper's single face mesh.
    alignment : str
        :data:`ALIGNMENTS`.
    neck : bool
        Pin the neck cuts onto each other (:data:`NECK_RATIO`).
    register : bool
        Fit the target's skin onto the source's (step 3 of :data:`ALIGNMENTS`).
    interpolation : str or None
        :data:`INTERPOLATIONS`; by default "surface" with the surface alignment, "2d"
        with the paper's.
    membrane : float
        The registration's membrane term against its thin plate
        (:data:`~mpeg4fba.cloning.registration.REGISTRATION_MEMBRANE`), 0 for the thin plate alone.
    facing : float
        With the surface interpolation, how much a source sheet facing against the target
        vertex counts against it (:data:`FACING`), 0 to turn it off.
    side_blend : float
        Target vertices whose side of a lip or eyelid slit the mesh says more weakly than
        this take both sides' motion (:data:`~mpeg4fba.cloning.lips.SIDE_BLEND`); 0: all
        of one side's, the paper's rule.
    refine : bool
        Go on to :data:`~mpeg4fba.cloning.registration.REGISTRATION_FINE_SCALES` for the
        surface points, the regions staying with the stiffer fit.
    correspondence : Correspondence or callable, optional
        In place of the correspondence step
        (:func:`~mpeg4fba.cloning.correspondence.correspond`): its record, or a function
        of the two :class:`~mpeg4fba.cloning.skin.Skin` s and the
        :class:`~mpeg4fba.cloning.correspondence.AlignOptions` returning one (a
        benchmark's ground truth).

    Attributes
    ----------
    src, tgt : Skin
        The two skins (rows of :attr:`weights`, :meth:`map_skin`).
    correspondence : Correspondence
        The correspondence step's record; ``aligned``, ``aligned_depth``,
        ``surface_points``, ``neck_pinned``... read through from it.
    source_regions, target_regions : array or None
        Each skin vertex's side of the lips and eyelids.
    target_sides : array or None
        The field that settled a target vertex's side by its mesh, NaN where the
        polygons alone did (:func:`~mpeg4fba.cloning.lips.slit_sides`); where it is weak
        the vertex takes both sides' motion (:data:`~mpeg4fba.cloning.lips.SIDE_BLEND`).
    weights : scipy.sparse.csr_matrix
        (Nt, Ns) the mapping.
    """

    def __init__(self, source: Union[FaceModel, "PreparedSource"], target: FaceModel, *,
                 support: float = 0.02,
                 samples: int = 8, scale_motion: bool = True, positions: Optional[str] = None,
                 triangulation: Union[str, Sequence] = "fixed", lips: bool = True,
                 eyelids: bool = True,
                 mouth_angle: Optional[float] = None, rigid_tolerance: float = 0.05,
                 min_motion: float = 1e-3, outside: str = "nearby", overlap: str = "nearest",
                 by_mesh: bool = True, alignment: str = "surface", neck: bool = True,
                 register: bool = True, interpolation: Optional[str] = None,
                 membrane: float = REGISTRATION_MEMBRANE, facing: float = FACING,
                 refine: bool = True, side_blend: float = SIDE_BLEND,
                 correspondence: Union[Correspondence, Callable[..., Correspondence],
                                       None] = None):
        # 0. the points, the options of the 2D interpolation, the placement
        prepared = source if isinstance(source, PreparedSource) else None
        if prepared is not None:
            positions = prepared.positions if positions is None else positions
            mouth_angle = prepared.mouth_angle if mouth_angle is None else mouth_angle
            if (positions, mouth_angle) != (prepared.positions, prepared.mouth_angle):
                raise ValueError(f"the source was prepared with positions={prepared.positions!r}, "
                                 f"mouth_angle={prepared.mouth_angle!r}, not {positions!r}, "
                                 f"{mouth_angle!r}: prepare it with the options of the cloning")
            source = prepared.face
        positions = "global" if positions is None else positions
        mouth_angle = MOUTH_ANGLE if mouth_angle is None else mouth_angle
        check_faces(source, target)
        #: the target with its seams joined, which the cloner works on
        #: (:mod:`~mpeg4fba.cloning.seams`); :meth:`clone` gives the triangles back
        self.welding = weld_seams(target)
        target = self.welding.face
        check_choice("outside", outside, OUTSIDE_RULES)
        self.outside = outside
        check_choice("overlap", overlap, OVERLAP_RULES)
        self.overlap = overlap
        if prepared is None:          # a prepared source was checked when prepared
            check_placement(source, "source")
        check_placement(target, "target")
        #: the target's part points carried over from the source (teeth and tongue given
        #: without points), id -> (mesh, vertex)
        matched, self.carried_points = match_parts(source, target)
        if self.carried_points:
            target = _with_points(target, self.carried_points)
            ids = point_order(self.carried_points)
            warnings.warn(f"the target's feature point{'s' if len(ids) > 1 else ''} "
                          f"{', '.join(ids)} (its teeth, tongue) were carried over from the "
                          "source's by its other points; give them to place them yourself",
                          CloneWarning, stacklevel=2)
        # eyes, teeth, tongue welded into another mesh become meshes of their own (the
        # cloned face is the target so split)
        if prepared is None:
            prepared = PreparedSource(source, positions=positions, mouth_angle=mouth_angle,
                                      placement=False)
        #: the source's side, worked out once (:class:`PreparedSource`)
        self.prepared = prepared
        target = separate_parts(target, matched)
        self.source, self.target = prepared.separated, target
        self.scale_motion = bool(scale_motion)
        self.by_mesh = bool(by_mesh)
        self.rigid_tolerance = float(rigid_tolerance)
        self.min_motion = float(min_motion)
        # 1. the parts and the skin
        self.source_parts = prepared.parts
        self.source_transforms = prepared.transforms
        #: part name -> why the target has no such part (for the warning)
        self.target_missing_parts: dict = {}
        self.target_parts = find_parts(target, self.target_missing_parts)
        self.src = prepared.skin
        self.tgt = Skin(target, self.target_parts, positions, mouth_angle)
        _check_skin(self.tgt, "target")
        # the options of the correspondence and the weights
        check_choice("alignment", alignment, ALIGNMENTS)
        self.alignment = alignment
        if interpolation is None:
            interpolation = "surface" if alignment == "surface" else "2d"
        check_choice("interpolation", interpolation, INTERPOLATIONS)
        if interpolation == "surface" and alignment != "surface":
            raise ValueError('interpolation="surface" needs alignment="surface" (the target '
                             "placed on the source's surface in 3D)")
        self.interpolation = interpolation
        self.neck = bool(neck)
        self.register = bool(register)
        self.refine = bool(refine)
        self.membrane = float(membrane)
        if not np.isfinite(self.membrane) or self.membrane < 0:
            raise ValueError(f"membrane must be a finite number >= 0, not {membrane!r}")
        self.facing = float(facing)
        if not np.isfinite(self.facing) or self.facing < 0:
            raise ValueError(f"facing must be a finite number >= 0, not {facing!r}")
        self.align_options = AlignOptions(triangulation, alignment, self.neck, self.register,
                                          self.refine, self.membrane, self.by_mesh)
        self.slits = (LIPS,) * bool(lips) + SLITS[1:] * bool(eyelids)
        self.side_blend = float(side_blend)
        if not np.isfinite(self.side_blend) or self.side_blend < 0:
            raise ValueError(f"side_blend must be a finite number >= 0, not {side_blend!r}")
        self.weight_options = WeightOptions(support, samples, interpolation, overlap, outside,
                                            self.facing, self.slits, self.by_mesh,
                                            self.side_blend)
        # 2. the correspondence
        if correspondence is None:
            correspondence = correspond(self.src, self.tgt, self.align_options)
        elif callable(correspondence):
            correspondence = correspondence(self.src, self.tgt, self.align_options)
        self.correspondence: Correspondence = self._checked(correspondence)
        # 3. the regions, 4. the mapping
        self.source_regions, self.target_regions, self.target_sides = slit_labels(
            self.src, self.tgt, self.correspondence.aligned, self.slits)
        self.weights = mapping_weights(self.src, self.tgt, self.correspondence,
                                       self.source_regions, self.target_regions,
                                       self.weight_options, self.target_sides)
        if self.welding.count:
            # a vertex's later copies (in no triangle now) move with its first
            self.weights = self.weights[self.welding.rows(self.tgt.offsets, self.weights.shape[0])]
        # 6. (in clone) the parts' motion
        self.part_mapping = PartMapping(self.src, self.tgt, self.source_parts,
                                        self.target_parts, self.source_transforms,
                                        scale_motion=self.scale_motion,
                                        rigid_tolerance=self.rigid_tolerance,
                                        min_motion=self.min_motion)

    def _checked(self, corr: Correspondence) -> Correspondence:
        """``corr`` when it fits the target's skin and the interpolation."""
        n = len(self.tgt.vertices)
        if not isinstance(corr, Correspondence) or len(corr.aligned) != n:
            raise ValueError(f"correspondence must be a Correspondence with a row for each "
                             f"of the target's {n} skin vertices, not {corr!r:.80}")
        if self.interpolation == "surface" and (corr.surface_points is None
                                                or len(corr.surface_points) != n):
            raise ValueError('interpolation="surface" needs a correspondence with the '
                             "target's surface points")
        return corr

    # -- the correspondence, read through ------------------------------------------------
    @property
    def aligned(self) -> np.ndarray:
        """(Nt, 2) the target's skin aligned in the source's 2D alignment space."""
        return self.correspondence.aligned

    @property
    def aligned_depth(self) -> np.ndarray:
        return self.correspondence.aligned_depth

    @property
    def alignment_ids(self) -> list:
        return self.correspondence.alignment_ids

    @property
    def alignment_triangles(self) -> np.ndarray:
        return self.correspondence.alignment_triangles

    @property
    def surface_points(self) -> Optional[np.ndarray]:
        """With alignment="surface": the target's skin vertices placed on the source's
        surface, in the source's normalised space (None with the paper's alignment)."""
        return self.correspondence.surface_points

    @property
    def neck_pinned(self) -> bool:
        """Whether the neck cuts were pinned onto each other (:data:`NECK_RATIO`)."""
        return self.correspondence.neck_pinned

    @property
    def source_skin(self) -> dict:
        """Source skin mesh name -> (first row, vertex count) in the stacked skin arrays."""
        return dict(self.src.offsets)

    @property
    def target_skin(self) -> dict:
        return dict(self.tgt.offsets)

    # -- the skin's motion -----------------------------------------------------------------
    @cached_property
    def motion_scale(self) -> Optional[np.ndarray]:
        """(Ns, 3) factors taking each source vertex's motion to the target's units
        (:func:`~mpeg4fba.cloning.transfer.motion_scale`); None with ``scale_motion=False``."""
        return motion_scale(self.src, self.tgt) if self.scale_motion else None

    def map_skin(self, motion: Union[np.ndarray, sp.spmatrix]) -> Union[np.ndarray, sp.csr_matrix]:
        """Target skin motions from source skin motions.

        ``motion`` is (Ns, 3) or (Ns, 3K) (K motions side by side, x y z each) in the
        face frame, rows in the order of :attr:`source_skin`; the answer has the
        target's rows (:attr:`target_skin`), sparse for a sparse ``motion``.
        """
        return map_skin(self.weights, motion, self.motion_scale)

    # -- the whole FAT ------------------------------------------------------------------------
    def clone(self) -> FaceModel:
        """The target with a FAT holding every table of the source's."""
        out = self.target.copy()
        out.fat = FAT()
        # 5. the skin's motion, every table at once
        tables, borders, columns = self.prepared.motion
        mapped = self.map_skin(columns).tocsc()
        installer = self.part_mapping.installer(out)
        new_tables = []
        col = 0
        for table, b in zip(tables, borders):
            nz = b[b != 0]
            block = mapped[:, col:col + 3 * len(nz)].toarray().reshape(mapped.shape[0], len(nz), 3)
            col += 3 * len(nz)
            # 7. the skin's entries; 6. the parts'
            meshes = mesh_entries(out, self.tgt.offsets, b, block, self.min_motion)
            part_meshes, rigid = self.part_mapping.mesh_entries(table, b, out, installer)
            transforms = self.part_mapping.transform_entries(table, b, installer) + rigid
            new_tables.append(FaceDefTable(table.fap, meshes + part_meshes, transforms,
                                           table.select))
        # 7. the FAT, and what was left out
        out.points = self.output_points
        dropped = {}
        for t in new_tables:
            lacking = out.points.missing(fap_points([t.fap]))
            if not t.meshes and not t.transforms:
                # moves nothing (the target lacks what it moved, said by the part notes):
                # it would only ask for its feature point
                continue
            if lacking:
                dropped.setdefault(tuple(lacking), []).append(t.fap)
            else:
                out.fat.add(t)
        out.invalidate()
        for message in installer.notes + self._skip_notes(installer.skipped, out.fat):
            warnings.warn(message, CloneWarning, stacklevel=2)
        for lacking, faps in dropped.items():
            warnings.warn(f"the target lacks feature point{'s' if len(lacking) > 1 else ''} "
                          f"{', '.join(lacking)} and the mapping can't put "
                          f"{'them' if len(lacking) > 1 else 'it'} (the source has "
                          f"{'them' if len(lacking) > 1 else 'it'} nowhere the target's skin "
                          f"maps to, or not at all): FAP{'s' if len(faps) > 1 else ''} "
                          f"{_runs(faps)} not cloned", CloneWarning, stacklevel=2)
        return self.welding.face_back(out)

    def _skip_notes(self, skipped: dict, fat: FAT) -> list:
        """One message per kind of part the target lacks (eyeballs, teeth, tongue): why,
        and which of the source's tables lost that motion or were left out."""
        out = []
        kinds = {"eye": "eyeballs", "teeth": "teeth", "tongue": "tongue"}
        for kind, label in kinds.items():
            parts = [p for p in skipped if p in PART_SPECS and PART_SPECS[p].kind == kind]
            if not parts:
                continue
            keys = set().union(*(skipped[p] for p in parts))
            gone = sorted(f for f, sel in keys if f > 2 and f not in fat.faps)
            kept = sorted(f for f, sel in keys if f > 2 and f in fat.faps)
            high = sorted({"visemes" if f == 1 else "expressions" for f, _ in keys if f <= 2})
            why = "; ".join((f"{p}: " if len(parts) > 1 else "")
                            + self.target_missing_parts.get(p, _no_point(p, self.target)) for p in parts)
            text = f"the target has no {' or '.join(parts) if kind == 'teeth' else label} ({why})"
            if gone:
                text += f"; FAP{'s' if len(gone) > 1 else ''} {_runs(gone)} not cloned"
            if kept or high:
                text += "; cloned without its motion: " + ", ".join(
                    ([f"FAP{'s' if len(kept) > 1 else ''} {_runs(kept)}"] if kept else []) + high)
            out.append(text)
        return out

    @cached_property
    def output_points(self) -> FeaturePointSet:
        """The target's feature points plus those the source's FAPs need that the target
        lacks and the mapping can put (:meth:`derive_points`)."""
        kinds = sorted({PART_SPECS[p].kind for p in self.target_parts if p in PART_SPECS})
        need = required_points(self.source.fat.faps, parts=kinds, fapu=True,
                               base=REQUIRED_POINTS)
        missing = self.target.points.missing(need)
        if not missing:
            return self.target.points
        found = self.derive_points(missing)
        if not found:
            return self.target.points
        positions = {k: self.target.points[k] for k in self.target.points}
        ties = dict(self.target.points.vertices)
        for k, (mesh, vertex) in found.items():
            positions[k] = self.target.world_vertices(mesh)[vertex]
            ties[k] = (mesh, vertex)
        return FeaturePointSet(positions, ties)

    def derive_points(self, ids: Sequence[str]) -> dict:
        """Point id -> (target skin mesh, vertex) for those of ``ids`` the source has on
        its skin: the target vertex the mapping places nearest the source's point, when
        it is placed within :data:`DERIVE_DISTANCE` of it (else the target has no such
        place, a face without ears, and the point stays missing);
        :func:`~mpeg4fba.cloning.correspondence.derive_points` at the surface points, or
        with the paper's alignment where the weights take the source's skin."""
        placed = self.surface_points if self.surface_points is not None else \
            np.asarray(self.weights @ self.src.normalised)
        return derive_points(self.src, self.tgt, placed, ids)


def _runs(numbers) -> str:
    """Sorted integers as runs: ``_runs([23, 24, 25, 43]) == "23-25, 43"``."""
    out, run = [], []
    for n in sorted(set(numbers)):
        if run and n != run[-1] + 1:
            out.append(f"{run[0]}-{run[-1]}" if len(run) > 2 else ", ".join(map(str, run)))
            run = []
        run.append(n)
    if run:
        out.append(f"{run[0]}-{run[-1]}" if len(run) > 2 else ", ".join(map(str, run)))
    return ", ".join(out)


def _no_point(part: str, face: FaceModel) -> str:
    """Why ``face`` has no ``part`` when no component was refused."""
    ids = PART_SPECS[part].points
    if any(fp in face.points for fp in ids):
        return f"no mesh of its own at its point {' or '.join(ids)}"
    return (f"no point {' or '.join(ids)} given, and no mesh shaped like the source's "
            "where it would be")


def _with_points(face: FaceModel, ties: dict) -> FaceModel:
    """A copy of ``face`` sharing its meshes, with the points ``ties`` (id -> (mesh,
    vertex)) added."""
    out = face.copy(share=True)
    positions = {k: face.points[k] for k in face.points}
    vertices = dict(face.points.vertices)
    for k, (mesh, vertex) in ties.items():
        positions[k] = face.world_vertices(mesh)[vertex]
        vertices[k] = (mesh, vertex)
    out.points = FeaturePointSet(positions, vertices)
    return out
