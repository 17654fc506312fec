"""Facial Motion Cloning end to end (mpeg4fba.cloning.fmc and its steps) on reference heads."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import mpeg4fba as fba
from mpeg4fba.cloning import (LOWER, REQUIRED_POINTS, UPPER, CloneWarning, FacialMotionCloner,
                              clone, find_parts)
from mpeg4fba.cloning.rigid import sphere_centre
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, rotation_matrices
from mpeg4fba.fba.featurepoints import FeaturePointError, FeaturePointSet
from mpeg4fba.formats.validate import validate
from mpeg4fba.models import reference_head


def quiet(fn, *a, **k):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*a, **k)
    return out, [str(w.message) for w in caught if issubclass(w.category, CloneWarning)]


@pytest.fixture(scope="module")
def source():
    return reference_head(resolution=0.6)


@pytest.fixture(scope="module")
def target():
    t = reference_head(resolution=0.5, face_width=1.15, jaw=0.9, nose=1.1, eye_spacing=1.1,
                       mouth_width=0.9, seed=4)
    t.fat = FAT()
    return t


@pytest.fixture(scope="module")
def cloned(source, target):
    return quiet(clone, source, target)[0]


def _world_motion(face, key, value):
    """World displacement of every mesh of ``face`` when table ``key`` is at ``value``."""
    fap, select = key
    if fap == 1:
        play = face.pose({}, visemes=(select, 0, int(value), 0))
    elif fap == 2:
        play = face.pose({}, expressions=(select, int(value), 0, 0, 0, 0))
    else:
        play = face.pose({fap: value})
    return {m: play.world_vertices(m)[0] - face.world_vertices(m) for m in face.meshes}


def test_every_table_is_cloned_with_the_source_borders(source, cloned):
    assert len(cloned.fat.faps) == 66
    assert len(cloned.fat.visemes) == 14 and len(cloned.fat.expressions) == 6
    for table in source.fat:
        new = cloned.fat[table.key]
        src_borders = np.union1d(np.concatenate([m.borders for m in table.meshes]), [0]) \
            if table.meshes else None
        for m in new.meshes:
            assert np.array_equal(m.borders, src_borders), table.key
        assert new.meshes or new.transforms, f"table {table.key} cloned to nothing"


def test_result_passes_validation_with_the_numeric_check(cloned):
    report = validate(cloned)
    assert report.ok, [str(f) for f in report.errors]
    assert not [f for f in report.findings if f.rule in ("FBA014", "FBA016")], \
        [str(f) for f in report.findings]
    measured = {k: v for k, v in report.ratios.items() if v is not None}
    assert len(measured) >= 60
    assert all(abs(v - 1) <= 0.05 for v in measured.values())


def test_input_faces_are_not_modified(source, target, cloned):
    assert len(target.fat) == 0
    assert cloned is not target
    assert set(target.transforms) == {"Head", "Jaw", "LeftEye", "RightEye"}


def test_cloning_a_face_onto_itself_reproduces_its_motion(source):
    same = reference_head(resolution=0.6)
    same.fat = FAT()
    # side_blend=0: a vertex where the lips meet takes its own side's motion alone (the
    # default blends in the other side's, which onto itself is off by a little)
    out = FacialMotionCloner(source, same, support=0.0, overlap="nearest",
                             side_blend=0).clone()
    for key in [(3, 0), (6, 0), (19, 0), (31, 0), (53, 0), (1, 4), (2, 6)]:
        value = 512 if key[0] > 2 else 63
        a = _world_motion(source, key, value)
        b = _world_motion(out, key, value)
        for mesh in ("Skin", "LowerTeeth", "LeftEyeball"):
            scale = max(np.abs(a[mesh]).max(), 1e-9)
            # vertices moving less than min_motion (1e-3) of the largest are left out
            assert np.abs(a[mesh] - b[mesh]).max() <= 1e-3 * scale + 1e-12, (key, mesh)


def test_scaled_target_gets_scaled_motion(source):
    big = reference_head(resolution=0.6)
    big.fat = FAT()
    s = 1.5
    for m in big.meshes.values():
        m.vertices = m.vertices * s
    for t in big.transforms.values():
        t.translation = tuple(np.asarray(t.translation) * s)
        t.center = tuple(np.asarray(t.center) * s)
    big.points = FeaturePointSet({k: big.points[k] * s for k in big.points}, big.points.vertices)
    big.fapu = None
    # (side_blend=0: onto the same face, scaled, each vertex's own side is exact)
    out = FacialMotionCloner(source, big, support=0.0, overlap="nearest",
                             side_blend=0).clone()
    for key, value in [((4, 0), 400), ((33, 0), 600), ((2, 1), 63)]:
        a = _world_motion(source, key, value)["Skin"]
        b = _world_motion(out, key, value)["Skin"]
        assert np.abs(b - s * a).max() <= 2e-3 * np.abs(s * a).max()


def test_missing_required_points_are_listed_for_both_faces(source, target):
    t = dataclasses.replace(target.meshes["Skin"], parent=None)
    bare = FaceModel([t], points=FeaturePointSet({k: target.points[k] for k in target.points
                                                  if k not in ("2.11", "3.7", "7.1")}))
    with pytest.raises(FeaturePointError) as e:
        FacialMotionCloner(source, bare)
    assert e.value.ids == ["2.11", "3.7", "7.1"]
    assert "target" in str(e.value) and "2.11, 3.7, 7.1" in str(e.value)
    assert set(REQUIRED_POINTS) >= {"3.5", "3.6", "7.1", "8.3", "8.4", "9.3"}


def test_lip_regions_follow_the_lips(source):
    c = FacialMotionCloner(source, _fresh(source))
    first = c.target_skin["Skin"][0]
    regions = c.target_regions[first:first + len(source.meshes["Skin"].vertices)]
    upper = source.regions["upper_lip"]
    lower = source.regions["lower_lip"]
    assert np.mean(regions[upper] == UPPER) > 0.9
    assert np.mean(regions[lower] == LOWER) > 0.9
    # the inner contours, one vertex apart across the slit, are never put in the wrong lip
    # (a vertex at the very corner may be neither)
    assert (regions[source.regions["lips_upper"]] != LOWER).all()
    assert (regions[source.regions["lips_lower"]] != UPPER).all()
    assert np.mean(regions[source.regions["lips_upper"]] == UPPER) > 0.8


def test_where_the_lips_meet_a_vertex_takes_both_sides_motion(source):
    """A target vertex whose side the mesh says weakly (round a mouth corner) takes both
    lips' weights, the upper's by (1 + side / side_blend) / 2: a corner point found a
    little off no longer gives it all of the wrong lip's motion.  (0.5 here, wider than
    the default SIDE_BLEND, so the reference head has rows enough to look at.)"""
    same = reference_head(resolution=0.6)
    blended = FacialMotionCloner(source, same, support=0.0, side_blend=0.5)
    plain = FacialMotionCloner(source, same, support=0.0, side_blend=0)
    side = blended.target_sides
    weak = np.flatnonzero(np.abs(np.nan_to_num(side, nan=1.0)) < 0.5)
    # a feature point's vertex keeps its side's motion whole (pinned onto the source's)
    points = blended.tgt.point_vertices()
    W, P = blended.weights, plain.weights
    assert np.isin(points, weak).any()
    assert abs(W[points] - P[points]).max() < 1e-12
    # even with every point vertex's field at 0 (a mid-lip point's two sides differ most)
    from mpeg4fba.cloning.weights import mapping_weights
    sides = side.copy()
    sides[points] = 0.0
    forced = mapping_weights(blended.src, blended.tgt, blended.correspondence,
                             blended.source_regions, blended.target_regions,
                             blended.weight_options, sides)
    assert abs(forced[points] - P[points]).max() < 1e-12
    weak = np.setdiff1d(weak, points)
    assert len(weak) >= 2
    assert np.allclose(np.asarray(W.sum(axis=1)).ravel(), 1.0)
    other = np.setdiff1d(np.arange(W.shape[0]), weak)
    assert abs(W[other] - P[other]).max() < 1e-12            # the rest as before
    # some weak rows now reach source vertices of both lips (others sit where both
    # sides' weights are the same)
    sreg = blended.source_regions
    on_up = np.asarray(W[weak][:, sreg == UPPER].sum(axis=1)).ravel()
    on_low = np.asarray(W[weak][:, sreg == LOWER].sum(axis=1)).ravel()
    both = (on_up > 0.05) & (on_low > 0.05)
    assert both.sum() >= 2
    assert (np.asarray(abs(W[weak] - P[weak]).sum(axis=1)).ravel()[both] > 0.1).all()
    with pytest.raises(ValueError, match="side_blend"):
        FacialMotionCloner(source, same, side_blend=-1)


def _other_lip_motion(source, target, **options) -> float:
    """Largest motion of the target's lip opposite the one a FAP moves, relative."""
    c = FacialMotionCloner(source, target, **options)
    first = c.target_skin["Skin"][0]
    worst = 0.0
    for fap, other in ((5, "lips_upper"), (4, "lips_lower")):
        truth = _world_motion(source, (fap, 0), 512)
        motion = np.zeros((len(c.src.vertices), 3))
        for name, (f, n) in c.source_skin.items():
            motion[f:f + n] = truth[name]
        got = c.map_skin(motion)[first + target.regions[other]]
        worst = max(worst, np.abs(got).max() / np.abs(motion).max())
    return worst


def test_without_lip_treatment_the_lips_pull_each_other(source, target):
    """A FAP moving one lip leaves the other lip's inner contour still, only with the
    lip regions, in the paper's 2D alignment (on a different face, where the contours
    don't coincide with the source's); the default surface alignment puts each lip on
    its own and keeps the regions too."""
    assert _other_lip_motion(source, target, alignment="paper", lips=True) < 1e-9
    assert _other_lip_motion(source, target, alignment="paper", lips=False) > 0.1
    assert _other_lip_motion(source, target) < 1e-9


def _fresh(face):
    out = reference_head(resolution=0.6)
    out.fat = FAT()
    return out


def test_map_skin_takes_dense_and_sparse(source, target):
    c = FacialMotionCloner(source, target)
    rng = np.random.default_rng(0)
    m = rng.normal(size=(len(c.src.vertices), 6)) * (rng.random((len(c.src.vertices), 1)) < 0.1)
    assert np.allclose(c.map_skin(m), c.map_skin(sp.csr_matrix(m)).toarray())
    # every row of the mapping is a partition of unity
    assert np.allclose(np.asarray(c.weights.sum(axis=1)).ravel(), 1.0)


def test_parts_are_found(source):
    parts = find_parts(source)
    assert parts["left eye"] == ["LeftEyeball"] and parts["right eye"] == ["RightEyeball"]
    assert parts["upper teeth"] == ["UpperTeeth"] and parts["lower teeth"] == ["LowerTeeth"]
    assert parts["tongue"] == ["Tongue"]


def flattened(face: FaceModel, drop=()) -> FaceModel:
    """The face as a dumb model: every mesh in world coordinates at the root, no FAT."""
    meshes = [FaceMesh(n, face.world_vertices(n), m.triangles) for n, m in face.meshes.items()]
    pts = FeaturePointSet({k: face.points[k] for k in face.points if k not in drop},
                          {k: v for k, v in face.points.vertices.items() if k not in drop})
    return FaceModel(meshes, points=pts, name="flat")


def test_transforms_are_installed_on_a_dumb_target(source):
    dumb = flattened(reference_head(resolution=0.5, face_width=1.1, seed=1))
    out, notes = quiet(clone, source, dumb)
    assert {"Head", "LeftEyeMotion", "RightEyeMotion", "LowerTeethMotion", "TongueMotion"} \
        <= set(out.transforms)
    assert any("installed Transform LeftEyeMotion" in n for n in notes)
    assert out.meshes["LeftEyeball"].parent == "LeftEyeMotion"
    assert out.transforms["LeftEyeMotion"].parent == "Head"
    # the neutral face did not move
    for name in dumb.meshes:
        assert np.allclose(out.world_vertices(name), dumb.world_vertices(name), atol=1e-12)
    # the eye turns about its own centre: FAP 23 (yaw) by 20 degrees
    c = sphere_centre(dumb.meshes["LeftEyeball"].vertices)
    w = out.pose({23: 20 * np.pi / 180 / 1e-5}).world_vertices("LeftEyeball")[0]
    r0 = np.linalg.norm(dumb.meshes["LeftEyeball"].vertices - c, axis=1)
    assert np.allclose(np.linalg.norm(w - c, axis=1), r0, atol=1e-9)
    # the head turns about 7.1
    p = out.pose({49: 0.3 / 1e-5}).world_vertices("Skin")[0]
    d0 = np.linalg.norm(dumb.meshes["Skin"].vertices - dumb.points["7.1"], axis=1)
    assert np.allclose(np.linalg.norm(p - dumb.points["7.1"], axis=1), d0, atol=1e-9)
    report = validate(out)
    assert report.ok and not [f for f in report.findings if f.rule == "FBA014"]


def test_wrong_eye_centre_is_fixed(source):
    t = reference_head(resolution=0.5, seed=2)
    t.fat = FAT()
    eye = t.transforms["LeftEye"]
    # move the eye's pivot off: the eyeball mesh is re-expressed so it does not move
    shift = np.array([0.0, 0.0, 0.01])
    eye.translation = tuple(np.asarray(eye.translation) + shift)
    t.meshes["LeftEyeball"].vertices = t.meshes["LeftEyeball"].vertices - shift
    out, notes = quiet(clone, source, t)
    assert any("centre of Transform LeftEye" in n for n in notes)
    c = sphere_centre(t.world_vertices("LeftEyeball"))
    w = out.pose({25: 0.2 / 1e-5}).world_vertices("LeftEyeball")[0]
    assert np.allclose(np.linalg.norm(w - c, axis=1),
                       np.linalg.norm(t.world_vertices("LeftEyeball") - c, axis=1), atol=1e-9)


def test_missing_part_warns_and_the_rest_goes_on(source):
    dumb = flattened(reference_head(resolution=0.5, seed=3), drop=("6.1", "6.2", "6.3", "6.4"))
    del dumb.meshes["Tongue"]
    out, notes = quiet(clone, source, dumb)
    assert sum("tongue" in n and "not cloned" in n for n in notes) == 1
    # the tongue's own FAPs are left out (their tables would move nothing), the rest kept
    assert set(out.fat.faps) == set(source.fat.faps) - {43, 44, 45, 46, 47}


def test_rigid_mesh_motion_becomes_a_transform():
    """A source whose lower teeth turn by morph target (FaceDefMesh), not by Transform."""
    src = reference_head(resolution=0.5)
    jaw = src.transforms["Jaw"]
    hinge = np.asarray(jaw.center)
    angle = np.radians(20.0)
    R = rotation_matrices((1, 0, 0), [angle])[0]
    world = src.world_vertices("LowerTeeth")
    moved = (world - hinge) @ R.T + hinge
    table = FaceDefTable(3, [FaceDefMesh("LowerTeeth", [0, 1000], np.arange(len(world)),
                                         (moved - world)[:, None, :] / 1000)])
    morph = FaceModel([FaceMesh(n, src.world_vertices(n), m.triangles) for n, m in src.meshes.items()],
                      points=src.points, fat=FAT([table]), name="morph")
    target = flattened(reference_head(resolution=0.5, jaw=1.1, seed=5))
    out, _ = quiet(clone, morph, target)
    entries = out.fat[3].transforms
    rot = [e for e in entries if e.field == "rotation"]
    assert rot and rot[0].transform == "LowerTeethMotion"
    assert abs(np.degrees(rot[0].rotation[3] * 1000) - 20.0) < 0.1
    assert abs(abs(rot[0].rotation[0]) - 1) < 1e-6
    assert not [m for m in out.fat[3].meshes if m.mesh == "LowerTeeth"]


def test_non_rigid_part_motion_is_mapped_vertex_to_vertex(source, cloned, target):
    # FAP 43 (thrust tongue tip) moves part of the tongue: the target's tongue tip follows
    tip = target.points.vertex("6.1")
    assert tip[0] == "Tongue"
    entries = [m for m in cloned.fat[44].meshes if m.mesh == "Tongue"]
    assert entries
    d = cloned.pose({44: 300}).vertices("Tongue")[0] - target.meshes["Tongue"].vertices
    expected = 300 * target.fapu.MNS
    assert abs(d[tip[1], 1] - expected) / expected < 0.1


def test_options_are_checked(source, target):
    with pytest.raises(ValueError, match="positions"):
        FacialMotionCloner(source, target, positions="sideways")
    with pytest.raises(ValueError, match="triangulation"):
        FacialMotionCloner(source, target, triangulation="voronoi")
    with pytest.raises(ValueError, match="interpolation must be one of"):
        FacialMotionCloner(source, target, interpolation="cubic")
    with pytest.raises(ValueError, match='needs alignment="surface"'):
        FacialMotionCloner(source, target, alignment="paper", interpolation="surface")
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="membrane must be a finite number"):
            FacialMotionCloner(source, target, membrane=bad)
        with pytest.raises(ValueError, match="facing must be a finite number"):
            FacialMotionCloner(source, target, facing=bad)


@pytest.mark.parametrize("options", [dict(positions="regional"), dict(triangulation="delaunay"),
                                     dict(scale_motion=False), dict(interpolation="2d"),
                                     dict(register=False), dict(alignment="paper"),
                                     dict(membrane=0.0), dict(facing=0.0),
                                     dict(refine=False)])
def test_variants_still_clone_everything(source, target, options):
    out, _ = quiet(clone, source, target, **options)
    assert len(out.fat) == len(source.fat)
    assert validate(out).ok


def test_facing_normals_follow_the_sources_winding_and_skip_coarse_meshes(source, target):
    from mpeg4fba.cloning.surface import vertex_normals
    from mpeg4fba.cloning.weights import facing_normals
    c, _ = quiet(FacialMotionCloner, source, target)
    n = facing_normals(c.src, c.tgt, c.surface_points, c.facing)
    length = np.linalg.norm(n, axis=1)
    assert np.allclose(length[length > 0], 1) and (length > 0).mean() > 0.8
    # facing the way the source's surface faces where each vertex lands
    w = c.weights
    src_n = vertex_normals(c.src.normalised, c.src.triangles)
    towards = np.einsum("ij,ij->i", n, np.asarray(w @ src_n))
    assert np.median(towards[length > 0]) > 0.9
    # a target wound the other way round gets the same normals
    flipped = FaceModel([FaceMesh(m.name, m.vertices, m.triangles[:, ::-1], m.parent)
                         for m in target.meshes.values()], target.transforms.values(),
                        points=target.points, fapu=target.fapu, fat=target.fat)
    c2, _ = quiet(FacialMotionCloner, source, flipped)
    assert np.allclose(facing_normals(c2.src, c2.tgt, c2.surface_points, c2.facing), n)
    # a target much coarser than the source: no normal counts
    assert not facing_normals(c.src, c.tgt, c.surface_points, c.facing, resolution=0.1).any()
    assert facing_normals(c.src, c.tgt, c.surface_points, 0.0) is None


def test_the_finer_fit_moves_the_surface_points_and_keeps_the_regions(source, target):
    """refine=True goes on fitting for the surface points (REGISTRATION_FINE_SCALES);
    the lip and eyelid regions stay with the stiffer fit, so they are those of
    refine=False, and the points still lie on the source's surface."""
    fine, _ = quiet(FacialMotionCloner, source, target)
    stiff, _ = quiet(FacialMotionCloner, source, target, refine=False)
    assert np.array_equal(fine.target_regions, stiff.target_regions)
    assert np.array_equal(fine.aligned, stiff.aligned)
    moved = np.linalg.norm(fine.surface_points - stiff.surface_points, axis=1)
    assert moved.max() > 1e-3          # it does move them (normalised units, ES0 = 1)
    assert np.median(moved) < 0.01     # ... by a little
    first, n = fine.tgt.offsets[fine.tgt.main]
    fs, ns = fine.src.offsets[fine.src.main]
    from mpeg4fba.cloning.surface import closest_points
    tris = source.meshes[fine.src.main].triangles
    _, _, d = closest_points(fine.surface_points[first:first + n],
                             fine.src.normalised[fs:fs + ns], tris)
    _, _, d0 = closest_points(stiff.surface_points[first:first + n],
                              fine.src.normalised[fs:fs + ns], tris)
    assert np.median(d) <= np.median(d0) + 1e-9
    # the feature points stay held
    rows = fine.tgt.main_point_rows()
    assert np.allclose(fine.surface_points[first + rows], stiff.surface_points[first + rows])
    # without the registration there is nothing to refine
    a, _ = quiet(FacialMotionCloner, source, target, register=False)
    b, _ = quiet(FacialMotionCloner, source, target, register=False, refine=False)
    assert np.array_equal(a.surface_points, b.surface_points)


def test_a_correspondence_stands_in_for_its_step(source, target):
    """FacialMotionCloner(..., correspondence=) takes the step's record, or a function of
    the two skins and the options returning one, in place of the step."""
    from mpeg4fba.cloning.correspondence import correspond
    c, _ = quiet(FacialMotionCloner, source, target)
    again, _ = quiet(FacialMotionCloner, source, target, correspondence=c.correspondence)
    assert (again.weights != c.weights).nnz == 0
    assert np.array_equal(again.target_regions, c.target_regions)
    seen = []

    def step(src, tgt, options):
        seen.append(options)
        return correspond(src, tgt, options)

    called, _ = quiet(FacialMotionCloner, source, target, register=False, correspondence=step)
    plain, _ = quiet(FacialMotionCloner, source, target, register=False)
    assert len(seen) == 1 and seen[0].register is False
    assert (called.weights != plain.weights).nnz == 0
    with pytest.raises(ValueError, match="correspondence must be a Correspondence"):
        FacialMotionCloner(source, target, correspondence=dataclasses.replace(
            c.correspondence, aligned=c.aligned[:5]))
    with pytest.raises(ValueError, match="surface points"):
        FacialMotionCloner(source, target, correspondence=dataclasses.replace(
            c.correspondence, surface_points=None))


def test_top_level_name():
    assert fba.clone is clone


def test_eyelid_margins_are_told_apart(source):
    c = FacialMotionCloner(source, _fresh(source))
    first = c.target_skin["Skin"][0]
    labels = c.target_regions[first:first + len(source.meshes["Skin"].vertices)]
    for side, up in (("left", 3), ("right", 5)):
        assert (labels[source.regions[f"{side}_margin_upper"]] == up).all()
        assert (labels[source.regions[f"{side}_margin_lower"]] == up + 1).all()
    off = FacialMotionCloner(source, _fresh(source), eyelids=False)
    assert set(np.unique(off.target_regions)) <= {0, 1, 2}


def test_paper_rules_are_available(source, target):
    """overlap="front" (smallest depth) and outside="global" (closest triangle among all)
    are the paper's letter for its 2D interpolation; both still give a compliant face."""
    out, _ = quiet(clone, source, target, alignment="paper", overlap="front", outside="global")
    assert validate(out).ok
    with pytest.raises(ValueError, match="outside"):
        FacialMotionCloner(source, target, outside="far")
    with pytest.raises(ValueError, match="overlap"):
        FacialMotionCloner(source, target, overlap="back")


def test_cli_clone_onto_a_mesh_with_a_feature_point_sidecar(tmp_path):
    """Bring your own face: a plain mesh file and a JSON sidecar of its feature points."""
    from click.testing import CliRunner

    from mpeg4fba.cli import main
    from mpeg4fba.formats.fpjson import write_feature_points_json
    from mpeg4fba.formats.wrl_face import save_face

    head = reference_head(resolution=0.5, face_width=1.1, seed=6)
    dumb = flattened(head)
    points = dumb.points
    dumb.points = FeaturePointSet()
    save_face(dumb, tmp_path / "mine.wrl")
    write_feature_points_json(points, tmp_path / "mine.json")
    out = tmp_path / "mine_animated.wrl"
    r = CliRunner().invoke(main, ["clone", str(tmp_path / "mine.wrl"), "--target-points",
                                  str(tmp_path / "mine.json"), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert "66 FAPs, 14 visemes, 6 expressions" in r.output and "0 errors" in r.output
    animated = fba.load_face(out)
    assert len(animated.fat.faps) == 66 and "Head" in animated.transforms
