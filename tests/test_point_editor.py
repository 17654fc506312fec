"""The feature point editor page (self-contained; in Debian's Chromium when it and Playwright
are installed: points selected, moved by the hook and by a real click, undone, saved as
sidecar JSON that differs from the input at the moved point only) and the points
picture (render_points)."""
from __future__ import annotations

import base64
import json
import math
import os
import random
import re
from pathlib import Path

import numpy as np
import pytest

from mpeg4fba.fba import FAPU, FeaturePointSet
from mpeg4fba.formats.fpjson import (dumps_feature_points_json, loads_confidences,
                                     loads_feature_points_json)
from mpeg4fba.models import reference_head
from mpeg4fba.render.point_editor import editor_data, point_editor_html, write_point_editor
from mpeg4fba.render.points import NO_CONFIDENCE, confidence_color, points_image, render_points

from _browser import browser, close_pages  # noqa: F401  (fixtures)

VIEWPORT = {"width": 1200, "height": 800}
MISSING = ("10.9", "10.10")
REASONS = {"10.9": "no ear found on the left", "10.10": "no ear found on the right",
           "2.1": "the chin is flat here"}
UNITS = "metres; x = the face's left, y = up, z = forward"
NOTES = ("the mouth is open <a little>",)


@pytest.fixture(scope="module")
def face():
    return reference_head()


@pytest.fixture(scope="module")
def points(face) -> FeaturePointSet:
    """The head's points less the two upper ear points (reported missing); 3.5 by vertex
    only, 9.15 by position only, so that every kind of entry is in the file."""
    fp = face.points
    keep = [k for k in fp.ids if k not in MISSING]
    positions = {k: fp[k] for k in keep if k != "3.5"}
    vertices = {k: v for k, v in fp.vertices.items() if k in keep and k != "9.15"}
    return FeaturePointSet(positions, vertices)


@pytest.fixture(scope="module")
def confidences(points) -> dict:
    """Every point but a few (shown as "no confidence"), spread over 0..1."""
    ids = points.ids
    return {k: round(i / (len(ids) - 1), 3) for i, k in enumerate(ids) if i % 9 != 4}


@pytest.fixture(scope="module")
def fapu() -> FAPU:
    return FAPU(0.0112, 0.064, 0.047, 0.021, 0.05)


@pytest.fixture(scope="module")
def page(face, points, confidences, fapu) -> str:
    return point_editor_html(face, points, confidences=confidences, missing=MISSING,
                             reasons=REASONS, title="Review <head>", fapu=fapu, units=UNITS,
                             filename="head.json", notes=NOTES)


# --------------------------------------------------------------------------- the page


def test_page_is_self_contained(page):
    assert page.startswith("<!DOCTYPE html>") and page.count("<html") == 1
    assert not re.search(r"<script[^>]*\bsrc\s*=|<link\b|<iframe\b|<img\b|@import", page, re.I)
    assert not re.search(r"\burl\(", page)            # CSS url() (not JS URL.createObjectURL)
    assert not re.search(r"https?://", page)
    imports = json.loads(re.search(r'<script type="importmap">(.*?)</script>', page, re.S).group(1))
    assert sorted(imports["imports"]) == ["three", "three/addons/controls/OrbitControls.js"]
    assert all(u.startswith("data:text/javascript;base64,") for u in imports["imports"].values())
    assert "Review &lt;head&gt;" in page and "<head>" in page and "Review <head>" not in page
    print(f"page: {len(page) / 1e6:.2f} MB")
    assert len(page) < 4_000_000


def test_page_carries_every_point_and_the_missing_ones(page, face, points, confidences):
    data = editor_data(page)
    assert [p["id"] for p in data["points"]] == points.ids
    for fp in points.ids:
        assert f'"id":"{fp}"' in page
    rows = {p["id"]: p for p in data["points"]}
    assert rows["3.5"]["position"] is None and rows["3.5"]["mesh"] == "LeftEyeball"
    assert rows["9.15"]["vertex"] is None and rows["9.15"]["position"] == points["9.15"].tolist()
    assert rows["3.5"]["shown"] == face.points["3.5"].tolist()     # placed on its vertex
    assert all(rows[k]["confidence"] == confidences.get(k) for k in rows)
    assert rows["2.1"]["reason"] == REASONS["2.1"]
    assert [(m["id"], m["reason"]) for m in data["missing"]] == [(k, REASONS[k]) for k in MISSING]
    assert "ear" in data["missing"][0]["name"]
    assert 'id="missing"' in page and "Missing required points" in page
    assert data["notes"] == list(NOTES)
    meshes = {m["name"]: m for m in data["meshes"]}
    assert set(meshes) == {n for n, m in face.meshes.items() if len(m.triangles)}
    skin = np.frombuffer(base64.b64decode(meshes["Skin"]["positions"]), "<f8").reshape(-1, 3)
    assert np.array_equal(skin, face.world_vertices("Skin"))
    tri = np.frombuffer(base64.b64decode(meshes["Skin"]["triangles"]), "<u4").reshape(-1, 3)
    assert np.array_equal(tri, face.meshes["Skin"].triangles)


def test_confidences_of_missing_points_are_dropped(face, points):
    data = editor_data(point_editor_html(face, points, missing=MISSING,
                                         confidences={"10.9": 0.0, " 2.1": 0.5}))
    assert {p["id"]: p["confidence"] for p in data["points"] if p["confidence"] is not None} == {"2.1": 0.5}


def test_bad_arguments_are_refused(face, points):
    with pytest.raises(ValueError, match="given and listed as missing"):
        point_editor_html(face, points, missing=["2.1"])
    with pytest.raises(ValueError, match="from 0 to 1"):
        point_editor_html(face, points, confidences={"2.1": 2})
    with pytest.raises(ValueError, match="10.9, which the points do not have"):
        point_editor_html(face, points, confidences={"10.9": 0.5})
    with pytest.raises(ValueError, match="not a feature point"):
        point_editor_html(face, points, missing=["12.1"])
    with pytest.raises(ValueError, match="Nose"):
        point_editor_html(face, FeaturePointSet({}, {"9.3": ("Nose", 1)}))
    with pytest.raises(ValueError, match="out of range"):
        point_editor_html(face, FeaturePointSet({}, {"9.3": ("Skin", 10**7)}))
    with pytest.raises(TypeError):
        point_editor_html(face, {"9.3": (0, 0, 0)})


def test_write_point_editor_is_atomic(face, points, tmp_path, monkeypatch):
    out = write_point_editor(tmp_path / "out" / "review.html", face, points)
    assert out == tmp_path / "out" / "review.html"
    text = out.read_text("utf-8")
    assert "<title>review</title>" in text and editor_data(text)["filename"] == "points.json"
    before = out.read_bytes()

    def broken(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError, match="disk full"):
        write_point_editor(out, face, points, title="Never written")
    assert out.read_bytes() == before
    assert sorted(p.name for p in out.parent.iterdir()) == ["review.html"]
    monkeypatch.undo()
    with pytest.raises(ValueError):                       # nothing written for a bad input
        write_point_editor(tmp_path / "bad.html", face, points, missing=["2.1"])
    assert not (tmp_path / "bad.html").exists()


# --------------------------------------------------------------------------- the picture


def test_render_points_draws_the_points(face, points, confidences, tmp_path):
    from matplotlib import image as mimage
    low = {k: 0.0 for k in points.ids[:20]}
    high = {k: 1.0 for k in points.ids[20:60]}            # the rest: no confidence (blue)
    path = render_points(face, points, tmp_path / "pts.png", confidences={**low, **high},
                         size=(800, 500))
    assert path == tmp_path / "pts.png" and os.listdir(tmp_path) == ["pts.png"]
    image = (mimage.imread(path)[..., :3] * 255).round().astype(int)
    assert image.shape == (500, 800, 3)
    plain = points_image(face, FeaturePointSet(), size=(800, 500))
    for colour in (confidence_color(0.0), confidence_color(1.0), NO_CONFIDENCE):
        rgb = np.round(np.array(colour) * 255).astype(int)
        near = np.abs(image - rgb).sum(-1) <= 12
        near_plain = np.abs(plain.astype(int) - rgb).sum(-1) <= 12
        views = slice(0, 500 - 44)                        # above the legend
        print(colour, near[views].sum(), near_plain[views].sum())
        assert near[views].sum() >= 60 > near_plain[views].sum() + 30
    with pytest.raises(ValueError, match="10.9"):
        render_points(face, points, tmp_path / "x.png", confidences={"10.9": 1.0})
    assert not (tmp_path / "x.png").exists()


def test_confidence_colours_run_red_yellow_green():
    r, g, b = confidence_color(0)
    assert r > 0.7 and g < 0.2 and b < 0.2
    r, g, b = confidence_color(0.5)
    assert r > 0.7 and g > 0.7 and b < 0.2
    r, g, b = confidence_color(1)
    assert g > 0.7 and r < 0.2 and b < 0.2
    assert confidence_color(None) == NO_CONFIDENCE


# --------------------------------------------------------------------------- in Chromium


@pytest.fixture(scope="module")
def page_path(page, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("editor") / "review.html"
    path.write_text(page, "utf-8")
    return path


class Editor:
    """An editor page open in Chromium, with its errors and the URLs it requested."""

    def __init__(self, browser, path: Path):
        self.errors, self.requests = [], []
        self.page = browser.new_page(viewport=VIEWPORT, accept_downloads=True)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.goto(path.as_uri())
        self.page.wait_for_function('document.body.dataset.ready === "1" || !!document.body.dataset.error',
                                    timeout=60_000)
        assert self.page.evaluate("document.body.dataset.error || ''") == ""

    def js(self, code: str, arg=None):
        return self.page.evaluate(code, arg)

    def save(self) -> str:
        with self.page.expect_download() as info:
            self.page.click("#save")
        download = info.value
        assert download.suggested_filename == "head.json"
        return Path(download.path()).read_text("utf-8")


@pytest.fixture
def editor(browser, page_path) -> Editor:
    return Editor(browser, page_path)


def _differences(before: FeaturePointSet, after: FeaturePointSet) -> set:
    ids = set(before.ids) | set(after.ids)
    return {k for k in ids
            if (k in before) != (k in after) or before.vertex(k) != after.vertex(k)
            or (k in before and not np.array_equal(before[k], after[k]))}


def test_unedited_page_saves_the_file_it_was_made_from(editor, points, confidences, fapu):
    expected = dumps_feature_points_json(points, fapu, UNITS, confidences=confidences)
    assert editor.js("__editor.json()") == expected
    assert editor.save() == expected
    assert all(u.startswith(("file:", "data:", "blob:")) for u in editor.requests), editor.requests
    assert editor.errors == []


def test_the_page_shows_the_missing_points_and_every_label(editor, points):
    text = editor.page.inner_text("#missing")
    for fp in MISSING:
        assert fp in text and REASONS[fp] in text
    assert editor.page.text_content("#missinghead") == "Missing required points (2)"
    assert editor.page.inner_text("#notes") == NOTES[0]          # shown as text, not markup
    labels = editor.js("[...document.querySelectorAll('#labels .lab')].map(e => e.textContent)")
    assert sorted(labels) == sorted(points.ids + list(MISSING))
    assert len(editor.page.query_selector_all("#rows tr")) == len(points.ids) + len(MISSING)


def test_move_by_hook_saves_that_point_only(editor, face, points, confidences):
    assert editor.js("__editor.select('2.1')") == "2.1"
    moved = editor.js("__editor.moveTo('Skin', 100)")
    assert moved == {"id": "2.1", "mesh": "Skin", "vertex": 100,
                     "position": face.world_vertices("Skin")[100].tolist()}
    saved = editor.save()
    after, fapu = loads_feature_points_json(saved)
    assert _differences(points, after) == {"2.1"}
    assert after.vertex("2.1") == ("Skin", 100)
    assert np.array_equal(after["2.1"], face.world_vertices("Skin")[100])
    conf = loads_confidences(saved)
    assert conf["2.1"] == 1.0 and {k: v for k, v in conf.items() if k != "2.1"} == \
        {k: v for k, v in confidences.items() if k != "2.1"}
    assert fapu is not None
    # undo brings the file back; a position picks the nearest vertex of a mesh
    assert editor.js("__editor.undo()") == "2.1"
    assert loads_feature_points_json(editor.js("__editor.json()"))[0] == points
    target = face.world_vertices("LeftEyeball")[7] + 1e-5
    editor.js("__editor.select('3.5')")
    assert editor.js("p => __editor.moveTo('LeftEyeball', p)", target.tolist())["vertex"] == 7
    editor.js("__editor.select('10.9')")              # a missing point is placed
    placed = editor.js("p => __editor.moveTo(null, p)", face.world_vertices("Skin")[42].tolist())
    assert placed["mesh"] == "Skin" and placed["vertex"] == 42
    after = loads_feature_points_json(editor.js("__editor.json()"))[0]
    assert _differences(points, after) == {"3.5", "10.9"}
    assert editor.errors == []


def _cheek_vertex(face, points) -> int:
    """A skin vertex on the right cheek, facing the camera, far from every point."""
    skin = face.world_vertices("Skin")
    p = points.resolve({n: face.world_vertices(n) for n in face.meshes}).positions
    d = np.min(np.linalg.norm(skin[:, None, :] - p[None], axis=2), axis=1)
    lo, hi = skin.min(axis=0), skin.max(axis=0)
    front = skin[:, 2] > lo[2] + 0.8 * (hi[2] - lo[2])
    cheek = front & (skin[:, 0] < -0.02) & (skin[:, 1] < 0.0) & (skin[:, 1] > -0.06)
    return int(np.flatnonzero(cheek)[np.argmax(d[cheek])])


def test_move_by_mouse_clicks(editor, face, points):
    editor.page.click('#rows tr[data-id="5.2"]')            # select by its row
    assert editor.js("__editor.selected()") == "5.2"
    assert "5.2" in editor.page.inner_text("#status")
    target = _cheek_vertex(face, points)
    at = editor.js("v => __editor.screenOf('Skin', v)", target)
    editor.page.mouse.click(at["x"], at["y"])
    assert editor.js("__editor.selected()") is None
    saved = editor.save()
    after = loads_feature_points_json(saved)[0]
    assert _differences(points, after) == {"5.2"}
    mesh, vertex = after.vertex("5.2")
    skin = face.world_vertices("Skin")
    gap = np.linalg.norm(skin[vertex] - skin[target]) / face.fapu.ES0
    print(f"clicked vertex {target}, got {vertex} ({gap:.1%} of ES0 away)")
    assert mesh == "Skin" and gap < 0.05
    assert np.array_equal(after["5.2"], skin[vertex]) and loads_confidences(saved)["5.2"] == 1.0
    assert editor.js("document.querySelector('#rows tr[data-id=\"5.2\"]').className") == "moved"
    assert "Skin #" + str(vertex) in editor.page.inner_text('#rows tr[data-id="5.2"]')
    # a click on a point's marker selects it; Undo (the button) puts 5.2 back
    at = editor.js("__editor.screenOf('9.3')")
    editor.page.mouse.click(at["x"], at["y"])
    assert editor.js("__editor.selected()") == "9.3"
    editor.page.keyboard.press("Escape")
    assert editor.js("__editor.selected()") is None
    editor.page.click("#undo")
    assert loads_feature_points_json(editor.js("__editor.json()"))[0] == points
    assert editor.page.is_disabled("#undo")
    assert editor.errors == []


def test_json_numbers_and_strings_match_python(editor):
    rng = random.Random(18)
    numbers = [0.0, -0.0, 1.0, -2.5, 1e-5, 1.5e-5, 0.0001, 0.00012345, 1e15, 1e16, 1.2345e16,
               123456789012345.6, 1e-300, 5e-324, 1.7976931348623157e308, 0.1, 1 / 3, -1e22,
               0.119, 1e21, 123.0]
    numbers += [rng.uniform(-1, 1) * 10 ** rng.randint(-12, 20) for _ in range(300)]
    # as JSON text: playwright before 1.6x hands 0.0 to the page as -0
    got = editor.js("s => JSON.parse(s).map(__editor.pyFloat)", json.dumps(numbers))
    assert got == [json.dumps(x) for x in numbers]
    strings = ["Skin", 'a "q" \\ b', "tab\there\nnl", "Tête", "\x7f\x01", "emoji \U0001F600", "</script>"]
    assert editor.js("xs => xs.map(__editor.pyStr)", strings) == [json.dumps(s) for s in strings]
    assert all(math.isfinite(x) for x in numbers)


def test_odd_mesh_names_round_trip(browser, tmp_path):
    from mpeg4fba.fba.face import FaceMesh, FaceModel
    quad = FaceMesh("Peau \"tête\"", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    pts = FeaturePointSet({"9.3": (0.1, 0.2, 1e-7)}, {"9.3": ("Peau \"tête\"", 2), "2.1": (None, 0)})
    path = write_point_editor(tmp_path / "q.html", FaceModel([quad]), pts, confidences={"2.1": 0.25})
    e = Editor(browser, path)
    assert e.js("__editor.json()") == dumps_feature_points_json(pts, confidences={"2.1": 0.25})
    assert e.errors == []


def test_a_z_up_head_opens_on_its_face(browser, tmp_path):
    """A head with +Z up facing +X (up and forward given, as ``mpeg4fba points`` passes
    the frame it found): the nose tip in the middle, the face's left eye on the
    viewer's right, the eyes above the mouth."""
    from mpeg4fba.fba.face import FaceMesh, FaceModel
    head = reference_head(resolution=0.5)
    R = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)        # y up -> z up, z -> x
    skin = head.meshes["Skin"]
    face = FaceModel([FaceMesh("Skin", head.world_vertices("Skin") @ R.T, skin.triangles)])
    ids = ("9.3", "3.5", "3.6", "8.1")
    pts = FeaturePointSet({k: head.points[k] @ R.T for k in ids})
    path = write_point_editor(tmp_path / "z.html", face, pts, up=R @ [0, 1, 0], forward=R @ [0, 0, 1])
    e = Editor(browser, path)
    at = {k: e.js("k => __editor.screenOf(k)", k) for k in ids}
    assert abs(at["9.3"]["x"] - (at["3.5"]["x"] + at["3.6"]["x"]) / 2) < 10
    assert at["3.5"]["x"] > at["9.3"]["x"] > at["3.6"]["x"]
    assert at["3.5"]["y"] < at["9.3"]["y"] < at["8.1"]["y"]
    assert e.errors == []


@pytest.mark.parametrize("view", ["front", "three-quarter", (20.0, -15.0)])
def test_project_points_lands_where_render_face_draws(view):
    from mpeg4fba.fba.face import FaceMesh, FaceModel
    from mpeg4fba.render.preview import project_points, render_face
    quad = FaceMesh("Skin", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    face = FaceModel([quad])
    fit = ((-2, -2, -1), (2, 2, 1))                 # room round the quad
    image = render_face(face, size=(160, 120), view=view, fit=fit, backend="matplotlib").astype(int)
    background = image[0, 0]
    corners = project_points(face, quad.vertices, size=(160, 120), view=view, fit=fit)
    centre = corners[:, :2].mean(axis=0)
    for col, row, depth in corners:
        assert depth > 0
        inside = np.round(centre + 0.9 * (np.array([col, row]) - centre)).astype(int)
        outside = np.round(centre + 1.1 * (np.array([col, row]) - centre)).astype(int)
        assert np.abs(image[inside[1], inside[0]] - background).sum() > 30
        assert np.abs(image[outside[1], outside[0]] - background).sum() <= 6
