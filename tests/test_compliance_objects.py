"""Compliance rules on FaceModel objects, and the numeric FAP check."""
import numpy as np
import pytest

from mpeg4fba.fba.compliance import RULES, Finding, Report, check_fap_ratios, check_fat
from mpeg4fba.fba.face import FaceMesh, FaceModel, FaceTransform
from mpeg4fba.fba.fat import FAT, FaceDefMesh, FaceDefTable, FaceDefTransform
from mpeg4fba.fba.featurepoints import FeaturePointSet

POINTS = {"3.1": (3, 5, 0), "3.3": (3, 4, 0), "3.5": (3, 4.5, 0), "3.6": (-3, 4.5, 0),
          "9.15": (0, 1, 1), "2.2": (0, -0.5, 1), "8.3": (2.5, -0.5, 0.8),
          "8.4": (-2.5, -0.5, 0.8), "2.1": (0, -3, 1)}
JAW = list(POINTS).index("2.1")


def face_with(*tables, points=POINTS):
    skin = FaceMesh("Skin", np.array(list(POINTS.values()), float), [[0, 1, 2]])
    eye = FaceTransform("LeftEye", translation=(3, 4.5, 0))
    return FaceModel([skin], [eye], points=FeaturePointSet(points), fat=FAT(tables))


MNS = 1.5 / 1024


def jaw_table(scale=1.0, borders=(0, 1024)):
    n = len(borders) - 1
    return FaceDefTable(3, [FaceDefMesh("Skin", list(borders), [JAW], [[0, -MNS * scale, 0]] * n)])


def codes(findings):
    return sorted(f.code for f in findings)


def test_a_compliant_face_has_no_findings_and_ratio_one():
    face = face_with(jaw_table(), FaceDefTable(23, transforms=[
        FaceDefTransform("LeftEye", 1, rotation=(0, 1, 0, 1e-5))]))
    assert check_fat(face) == []
    findings, ratios = check_fap_ratios(face)
    assert findings == [] and ratios[3] == pytest.approx(1.0) and ratios[23] == pytest.approx(1.0)


@pytest.mark.parametrize("tables, expected", [
    ([FaceDefTable(70)], ["FBA004"]),
    ([FaceDefTable(1, select=15)], ["FBA005"]),
    ([FaceDefTable(2, select=7)], ["FBA005"]),
    ([FaceDefTable(3, [FaceDefMesh("Lips", [0, 1], [0], [[0, 1, 0]])])], ["FBA006"]),
    ([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1], [99], [[0, 1, 0]])])], ["FBA007"]),
    ([FaceDefTable(3, [FaceDefMesh("Skin", [0, 2, 1], [0], [[0, 1, 0]] * 2)])], ["FBA008"]),
    ([FaceDefTable(3, [FaceDefMesh("Skin", [1, 2], [0], [[0, 1, 0]])])], ["FBA008"]),
    ([FaceDefTable(3, [FaceDefMesh("Skin", [0, 1], [0, 1], [[0, 1, 0]])])], ["FBA009"]),
    ([FaceDefTable(23, transforms=[FaceDefTransform("Head", 1)])], ["FBA010"]),
    ([jaw_table(), jaw_table()], ["FBA012"]),
    ([jaw_table(borders=(-1024, 0, 1024))], ["FBA013"]),
])
def test_each_rule_fires_alone(tables, expected):
    assert codes(check_fat(face_with(*tables))) == expected


def test_missing_feature_points_and_fapu():
    pts = {k: v for k, v in POINTS.items() if k not in ("2.1", "8.4")}
    found = check_fat(face_with(jaw_table(), points=pts))
    assert codes(found) == ["FBA002", "FBA003"]
    assert "2.1" in found[0].message and "8.4" in found[1].message


def test_numeric_check_flags_faps_more_than_5_percent_off():
    findings, ratios = check_fap_ratios(face_with(jaw_table(1.1)))
    assert codes(findings) == ["FBA014"] and ratios[3] == pytest.approx(1.1)
    assert "open_jaw" in findings[0].message
    findings, _ = check_fap_ratios(face_with(jaw_table(1.04)))
    assert findings == []
    findings, _ = check_fap_ratios(face_with(jaw_table(0.0)))
    assert codes(findings) == ["FBA016"]


def test_findings_and_reports_read_well():
    f = Finding("FBA008", "FAP 3: interval borders [1, 2] have no 0", "a.wrl", 12, 5)
    assert str(f) == "a.wrl:12:5: error FBA008: FAP 3: interval borders [1, 2] have no 0"
    r = Report("a.wrl", [f, Finding("FBA014", "off", "a.wrl", 3)])
    assert not r.ok and len(r.errors) == 1
    assert str(r).splitlines()[0] == "a.wrl: 1 error(s), 1 warning(s)"
    assert r.as_dict()["findings"][0]["code"] == "FBA008"
    assert all(rule.severity in ("error", "warning") for rule in RULES.values())


def seam_face(tie=None, lower=0.0):
    """A closed mouth: 2.3 on the seam, where the upper lip's vertex (index 0) and the
    lower lip's (index 1) are copies of one place (the lower ``lower`` below it)."""
    pts = dict(POINTS, **{"2.3": (0, -0.5, 1)})
    verts = np.array([(0, -0.5, 1), (0, -0.5 - lower, 1), (1, 0, 1), (1, -1, 1)], float)
    skin = FaceMesh("Skin", verts, [[0, 2, 1], [1, 2, 3]])
    raise_lower = FaceDefTable(5, [FaceDefMesh("Skin", [0, 1024], [1], [[0, MNS, 0]])])
    ties = {"2.3": tie} if tie else {}
    return FaceModel([skin], points=FeaturePointSet(pts, ties), fat=FAT([raise_lower]))


def test_a_point_on_a_seam_is_measured_on_the_copy_its_fap_moves():
    # the upper copy is as near (or nearer by a hair): the lower lip's FAP moves the
    # lower copy, and that is what is measured
    for lower in (0.0, 1e-6):
        findings, ratios = check_fap_ratios(seam_face(lower=lower))
        assert findings == [] and ratios[5] == pytest.approx(1.0)
    # a vertex tie names the place: tied to the upper copy, the lower copy is measured
    # too; tied to a vertex elsewhere, only that one (which the table moves not at all)
    findings, ratios = check_fap_ratios(seam_face(tie=("Skin", 0)))
    assert findings == [] and ratios[5] == pytest.approx(1.0)
    findings, _ = check_fap_ratios(seam_face(tie=("Skin", 2)))
    assert codes(findings) == ["FBA016"]
    # a copy further than the seam's tolerance is another place, not measured
    findings, _ = check_fap_ratios(seam_face(lower=0.01))
    assert codes(findings) == ["FBA016"]
