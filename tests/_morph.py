"""Shared by the morph-target tests (test_morph_fat.py, test_morph_targets.py): a small
neutral of two grid meshes, random moves of it, and faces and poses made from it."""
from __future__ import annotations

import numpy as np
import pytest

from mpeg4fba.fba.face import FaceMesh, FaceModel

EXACT = dict(rtol=0, atol=1e-9)


def grid_vertices(n: int, z: float = 0.0) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    return np.column_stack([x.ravel(), y.ravel(), np.full(n * n, z)])


def grid_triangles(n: int) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    return np.concatenate([np.column_stack([a, a + 1, a + n + 1]),
                           np.column_stack([a, a + n + 1, a + n])])


@pytest.fixture
def neutral() -> dict:
    return {"Skin": grid_vertices(6), "Teeth": grid_vertices(3, z=-0.1)}


def moved_copy(neutral: dict, seed: int, mesh: str = "Skin", k: int = 5, scale: float = 0.05) -> dict:
    """The neutral with ``k`` vertices of ``mesh`` moved at random."""
    rng = np.random.default_rng(seed)
    out = {name: v.copy() for name, v in neutral.items()}
    idx = rng.choice(len(out[mesh]), size=k, replace=False)
    out[mesh][idx] += rng.normal(scale=scale, size=(k, 3))
    return out


def face_of(neutral: dict, fat) -> FaceModel:
    return FaceModel([FaceMesh(n, v, np.empty((0, 3))) for n, v in neutral.items()], fat=fat)


def posed_vertices(face: FaceModel, faps=None, visemes=None, expressions=None) -> dict:
    pb = face.pose(faps or {}, visemes=visemes, expressions=expressions)
    return {name: pb.vertices(name)[0] for name in face.meshes}


def assert_same_shape(got: dict, want: dict) -> None:
    assert set(got) == set(want)
    for name in want:
        np.testing.assert_allclose(got[name], want[name], **EXACT, err_msg=name)
