"""The OpenGL render path (mpeg4fba.render.gl) against the matplotlib one, and the choice
between them: "auto" falls back silently, "gl" says why it can't, MPEG4FBA_RENDER."""
from __future__ import annotations

import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.models import reference_head
from mpeg4fba.render import gl, preview
from mpeg4fba.render.preview import render_face

SIZE = (200, 240)


@pytest.fixture
def needs_gl():
    ok, reason = gl.gl_available()
    if not ok:
        pytest.skip(f"OpenGL rendering is not available here: {reason}")


@pytest.fixture(autouse=True)
def _no_env(monkeypatch):
    monkeypatch.delenv("MPEG4FBA_RENDER", raising=False)


@pytest.fixture(scope="module")
def head():
    return reference_head(resolution=0.5)


@pytest.fixture
def gl_off(monkeypatch):
    """GL reported unavailable, as on a machine without moderngl."""
    monkeypatch.setattr(gl, "gl_available", lambda: (False, "forced off by the test"))


def _silhouette(image: np.ndarray) -> np.ndarray:
    """Pixels that are not the background (the corner's colour)."""
    return np.abs(image.astype(int) - image[0, 0]).sum(axis=2) > 6


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / (a | b).sum())


def _interior(mask: np.ndarray, r: int = 2) -> np.ndarray:
    """``mask`` less a band of ``r`` pixels along its edges, where the two renderers
    antialias differently (Agg's unsmoothed outlines, GL's multisampling)."""
    out = mask.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out &= np.roll(mask, (dy, dx), axis=(0, 1))
    return out


def _mean_colour_gap(soft: np.ndarray, hard: np.ndarray) -> float:
    """Largest difference (of 255) between the mean colours inside the face."""
    inside = _interior(_silhouette(soft) & _silhouette(hard))
    return float(np.abs(soft[inside].mean(axis=0) - hard[inside].mean(axis=0)).max())


def _quad(name: str = "Skin") -> FaceModel:
    return FaceModel([FaceMesh(name, [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                               [[0, 1, 2], [0, 2, 3]])])


POSES = {"neutral": None, "open jaw": {"open_jaw": 800, "raise_b_midlip": -760},
         "smile": {"stretch_l_cornerlip": 300, "stretch_r_cornerlip": 300,
                   "raise_l_cornerlip": 250, "raise_r_cornerlip": 250}}


@pytest.mark.parametrize("view", ["front", "three-quarter", "profile", (-25.0, -12.0)])
@pytest.mark.parametrize("pose", list(POSES))
def test_gl_matches_matplotlib(needs_gl, head, view, pose):
    kw = dict(size=SIZE, view=view)
    soft = render_face(head, POSES[pose], backend="matplotlib", **kw)
    hard = render_face(head, POSES[pose], backend="gl", **kw)
    assert preview.last_backend == "gl"
    assert hard.shape == soft.shape == (SIZE[1], SIZE[0], 3) and hard.dtype == np.uint8
    assert (hard[0, 0] == soft[0, 0]).all()                    # the same background
    # the same framing (measured: IoU 0.975-0.981 at 200x240, 0.993 at 800x800)
    assert _iou(_silhouette(soft), _silhouette(hard)) > 0.95
    # the same colours and lights: mean colour inside the face within 3 levels of 255
    # (measured: 0.7-1.6, Agg's Gouraud triangles come out a little darker)
    assert _mean_colour_gap(soft, hard) < 3
    # and pixel by pixel, mostly (the depth buffer fixes the painter's sort in places)
    inside = _interior(_silhouette(soft) & _silhouette(hard))
    assert np.abs(soft[inside].astype(int) - hard[inside]).mean() < 6


@pytest.mark.parametrize("kw", [dict(shading="flat"), dict(cull=False, view="profile"),
                                dict(hide=("Hair",), background=(0.1, 0.1, 0.1),
                                     light=(0.0, 0.2, 1.0)),
                                dict(colors={"Skin": (0.5, 0.6, 0.7)}, size=(150, 90))])
def test_gl_matches_matplotlib_options(needs_gl, head, kw):
    kw = {"size": SIZE, **kw}
    soft = render_face(head, backend="matplotlib", **kw)
    hard = render_face(head, backend="gl", **kw)
    assert (hard[0, 0] == soft[0, 0]).all()
    # measured 0.96-0.98: Agg's outlines widen the software silhouette by about half a
    # pixel, which weighs more in the small 150x90 image
    assert _iou(_silhouette(soft), _silhouette(hard)) > 0.93
    assert _mean_colour_gap(soft, hard) < 3


def test_plain_colours_are_exact(needs_gl):
    """A flat quad facing the light: one colour, the same byte in both renderers."""
    for shading in ("gouraud", "flat"):
        kw = dict(size=(48, 40), colors={"Skin": (0.2, 0.6, 0.9)}, light=(0, 0, 1),
                  shading=shading)
        soft = render_face(_quad(), backend="matplotlib", **kw)
        hard = gl.render_face_gl(_quad(), **kw)
        assert hard[20, 24].tolist() == soft[20, 24].tolist()
        assert hard[0, 0].tolist() == soft[0, 0].tolist()


def test_gl_poses_change_pixels(needs_gl, head):
    neutral = render_face(head, size=SIZE, backend="gl")
    assert np.array_equal(neutral, render_face(head, None, size=SIZE, backend="gl"))
    opened = render_face(head, POSES["open jaw"], size=SIZE, backend="gl")
    changed = np.abs(opened.astype(int) - neutral).sum(axis=2) > 30
    assert changed.sum() > 100
    assert np.flatnonzero(changed.any(axis=1)).min() > SIZE[1] // 2   # the lower face only
    for view in ("three-quarter", "profile"):
        assert not np.array_equal(render_face(head, size=SIZE, view=view, backend="gl"), neutral)
    from mpeg4fba.fba import FapStream
    play = head.play(FapStream.from_values({"head_yaw": [0, 30000]}))
    a = render_face(head, play, frame=0, size=SIZE, backend="gl")
    b = render_face(head, play, frame=1, size=SIZE, backend="gl")
    assert np.array_equal(a, neutral) and not np.array_equal(a, b)


def test_gl_errors_are_the_software_ones(needs_gl, head):
    with pytest.raises(ValueError):
        render_face(head, view="top", backend="gl")
    with pytest.raises(IndexError):
        render_face(head, head.pose({}), frame=5, backend="gl")
    with pytest.raises(ValueError):
        gl.render_face_gl(head, size=(0, 10))


def test_auto_uses_gl_and_threads_share_the_context(needs_gl, head):
    image = render_face(head, size=(90, 100))
    assert preview.last_backend == "gl" and preview.last_fallback is None
    with ThreadPoolExecutor(4) as pool:
        images = list(pool.map(lambda _: render_face(head, size=(90, 100)), range(8)))
    assert all(np.array_equal(im, image) for im in images)
    ok, reason = gl.gl_available()
    assert ok and "multisampling" in reason


def test_environment_variable(monkeypatch, head):
    soft = render_face(head, size=(60, 70), backend="matplotlib")
    monkeypatch.setenv("MPEG4FBA_RENDER", "matplotlib")
    assert np.array_equal(render_face(head, size=(60, 70)), soft)
    assert preview.last_backend == "matplotlib"
    monkeypatch.setenv("MPEG4FBA_RENDER", "Direct3D")
    with pytest.raises(ValueError, match="MPEG4FBA_RENDER"):
        render_face(head, size=(60, 70))
    monkeypatch.setenv("MPEG4FBA_RENDER", "matplotlib")
    # an explicit backend wins over the variable
    if gl.gl_available()[0]:
        render_face(head, size=(60, 70), backend="gl")
        assert preview.last_backend == "gl"


def test_fallback_when_gl_is_off(gl_off, monkeypatch, head):
    soft = render_face(head, size=(60, 70), backend="matplotlib")
    image = render_face(head, size=(60, 70))                    # "auto": silently software
    assert np.array_equal(image, soft)
    assert preview.last_backend == "matplotlib"
    assert preview.last_fallback == "forced off by the test"
    with pytest.raises(RuntimeError, match="OpenGL rendering is not available: forced off"):
        render_face(head, size=(60, 70), backend="gl")
    with pytest.raises(RuntimeError, match="forced off"):
        gl.render_face_gl(head, size=(60, 70))
    monkeypatch.setenv("MPEG4FBA_RENDER", "gl")                 # demanded: an error too
    with pytest.raises(RuntimeError, match="forced off"):
        render_face(head, size=(60, 70))
    with pytest.raises(ValueError, match="backend"):
        render_face(head, backend="vulkan")


def test_fallback_when_a_draw_fails(needs_gl, monkeypatch, head):
    """GL up but unable to draw this image (too large for its framebuffers)."""
    renderer = gl._renderer()[2]
    monkeypatch.setattr(renderer, "max_size", 64)
    image = render_face(head, size=(80, 70))
    assert preview.last_backend == "matplotlib" and "larger than" in preview.last_fallback
    assert np.array_equal(image, render_face(head, size=(80, 70), backend="matplotlib"))
    with pytest.raises(gl.GLRenderError, match="larger than"):
        render_face(head, size=(80, 70), backend="gl")
    render_face(head, size=(60, 50))
    assert preview.last_backend == "gl"


def test_reasons(monkeypatch):
    """Each way GL can be missing says so (without making a context)."""
    monkeypatch.setitem(sys.modules, "moderngl", None)         # import fails
    ok, reason, renderer = gl._create()
    assert not ok and renderer is None and "pip install moderngl" in reason
    monkeypatch.undo()
    if gl.gl_available()[0] or "moderngl" not in gl.gl_available()[1]:
        monkeypatch.setattr(gl, "_library", lambda name, fallback: None)
        ok, reason, _ = gl._create()
        assert not ok and "no EGL library" in reason and "libegl1" in reason


def test_forked_child_does_not_use_gl(monkeypatch):
    """Mesa hangs in a child forked after its parent made a context: such a child says
    so (here a parent process is faked in the cache; nothing is forked)."""
    monkeypatch.setattr(gl, "_state", {-1: (True, "the parent's", object())})
    ok, reason = gl.gl_available()
    assert not ok and "fork" in reason
