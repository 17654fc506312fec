"""PNG previews: the software renderer, grids, atomic PNG files, the shape gallery."""
from __future__ import annotations

import os

import numpy as np
import pytest

from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.models import reference_head
from mpeg4fba.render import VIEWS, mesh_color, render_face, render_grid, save_png
from mpeg4fba.render.gallery import gallery_shapes, shape_gallery


@pytest.fixture(scope="module")
def head():
    return reference_head(resolution=0.5)


def _background(image: np.ndarray) -> np.ndarray:
    return image[0, 0]


def test_image_shape_and_the_face_is_visible(head):
    image = render_face(head, size=(160, 200))
    assert image.shape == (200, 160, 3) and image.dtype == np.uint8
    bg = _background(image)
    centre = image[70:130, 55:105]
    assert (np.abs(centre.astype(int) - bg).sum(axis=2) > 30).mean() > 0.95
    # the head is framed: there is background all round
    assert (image[:, 0] == bg).all() and (image[:, -1] == bg).all()


def test_views_and_shading(head):
    front = render_face(head, size=(120, 140))
    for view in ("three-quarter", "profile", (20.0, -10.0)):
        assert not np.array_equal(render_face(head, size=(120, 140), view=view), front)
    flat = render_face(head, size=(120, 140), shading="flat")
    assert flat.shape == front.shape and not np.array_equal(flat, front)
    with pytest.raises(ValueError):
        render_face(head, view="top")
    with pytest.raises(ValueError):
        render_face(head, shading="phong")
    assert set(VIEWS) >= {"front", "three-quarter"}


def test_two_poses_differ(head):
    neutral = render_face(head, size=(120, 140))
    again = render_face(head, None, size=(120, 140))
    assert np.array_equal(neutral, again)                       # deterministic
    opened = render_face(head, {"open_jaw": 800, "raise_b_midlip": -760,
                                "raise_b_midlip_o": -760}, size=(120, 140))
    assert not np.array_equal(opened, neutral)
    changed = np.abs(opened.astype(int) - neutral).sum(axis=2) > 30
    rows = np.flatnonzero(changed.any(axis=1))
    assert rows.min() > 60                                      # the change is in the lower face
    smile = render_face(head, head.pose({}, expressions=[1, 63, 0, 0, 0, 0]), size=(120, 140))
    assert not np.array_equal(smile, neutral)


def test_frames_of_a_playback(head):
    from mpeg4fba.fba import FapStream
    stream = FapStream.from_values({"head_yaw": [0, 30000]})
    play = head.play(stream)
    a = render_face(head, play, frame=0, size=(80, 90))
    b = render_face(head, play, frame=1, size=(80, 90))
    assert np.array_equal(a, render_face(head, size=(80, 90)))
    assert not np.array_equal(a, b)
    assert np.array_equal(render_face(head, stream, frame=1, size=(80, 90)), b)
    with pytest.raises(IndexError):
        render_face(head, play, frame=5)
    with pytest.raises(TypeError):
        render_face(head, "open_jaw")


def test_colours(head):
    assert mesh_color("UpperTeeth") != mesh_color("Skin")
    image = render_face(head, size=(100, 120))
    grey = render_face(head, size=(100, 120), colors={k: (0.5, 0.5, 0.5) for k in head.meshes})
    assert not np.array_equal(image, grey)
    # a plain face without colours of its own renders in name colours
    quad = FaceMesh("Tongue", [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    im = render_face(FaceModel([quad]), size=(40, 40))
    r, g, b = im[20, 20].astype(int)
    assert r > g and r > b                                      # tongue pink


def test_grid_and_png(tmp_path):
    tiles = [np.full((30, 40, 3), v, np.uint8) for v in (0, 80, 160)]
    grid = render_grid(tiles, ["a", "b", "c"], cols=2)
    assert grid.shape[1] == 80 and grid.shape[0] > 60 and grid.dtype == np.uint8
    assert render_grid(tiles, cols=3).shape == (30, 120, 3)
    with pytest.raises(ValueError):
        render_grid(tiles, ["a"])
    with pytest.raises(ValueError):
        render_grid([tiles[0], np.zeros((5, 5, 3), np.uint8)])
    path = save_png(tmp_path / "sub" / "grid.png", grid)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert os.listdir(tmp_path / "sub") == ["grid.png"]         # no temporary file left
    mask = os.umask(0)
    os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask          # not mkstemp's 0600
    from matplotlib import image as mimage
    back = mimage.imread(path)
    assert back.shape[:2] == grid.shape[:2]
    with pytest.raises(ValueError):
        save_png(tmp_path / "bad.png", np.zeros((4, 4)))


def test_gallery(head):
    shapes = gallery_shapes(head)
    assert len(shapes) == 21 and shapes[0] == ("neutral", None)
    assert shapes[1][0] == "1 joy" and shapes[7][0].startswith("1 PP")
    image = shape_gallery(head, size=(60, 70), shapes=shapes[:3], cols=3)
    assert image.shape[1] == 180 and image.shape[0] > 70
