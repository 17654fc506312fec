"""The registration of one surface onto another (the cloner's non-rigid ICP) and the
smoothest field over a surface, with the sparse solves both stand on.

>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); T = np.array([[0, 1, 3], [0, 3, 2]])
>>> out = register_surface(V, T, V + [0, 0, 0.5], np.array([], dtype=int), V, T)
>>> bool(np.abs(out[:, 2]).max() < 1e-9)
True
"""
from __future__ import annotations

from typing import Optional

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from .surface import vertex_normals

__all__ = ["register_surface", "surface_biharmonic", "SPDFactoriser", "REGISTRATION_SCALES",
           "REGISTRATION_FINE_SCALES", "REGISTRATION_MEMBRANE", "REGISTRATION_CANDIDATES"]

#: The stiffness schedule of :func:`register_surface`: the length scales (in the units of
#: the vertices; the cloner's normalised space, where the eye separation is 1) over which
#: the fit may bend, coarse to fine.  Measured on ICT identities (benchmarks/bench_clone_ict.py):
#: starting stiffer changes nothing; a fit going on to finer scales follows the source's
#: facets, which moves some vertices across the mouth's mid line, so the cloner decides
#: its lip regions here and takes only its surface points finer
#: (:data:`REGISTRATION_FINE_SCALES`).
REGISTRATION_SCALES = (1.0, 0.5, 0.25, 0.125, 0.0625)
#: Where the cloner's fit goes on after :data:`REGISTRATION_SCALES` (``refine=True``):
#: the lip and eyelid regions are decided on the fit at 1/16, and the surface points the
#: motion is taken from come from these finer scales.  Decided at the finer scales, the
#: regions go wrong at the mouth corners: a vertex following the source's facets crosses
#: the mid line of the mouth (ICT 9 -> 10 onto the full mesh: a lower-lip vertex on the
#: upper lip, 15 % of the eye distance off under jawOpen).  Measured on six ICT pairs
#: (``benchmarks/bench_clone_ict.py --pairs``), against stopping at 1/16: onto the full
#: mesh the mean error 0.065 -> 0.063 % IOD, errors over 2 % 632 -> 538, flips 21 -> 15,
#: median of the largest errors 3.06 -> 2.97; onto the decimated targets 0.061 -> 0.060,
#: 78 -> 76 and 2.83 -> 2.71, for a tenth more set-up (0.45 of 5.3 s on the
#: 30,000-vertex reference heads, ``benchmarks/bench_clone.py``).  Going on to 1/128
#: and 1/256 moves the worst vertex of the decimated 1 -> 2 (a mouth corner) only from
#: 2.36 to 2.28 % IOD.
REGISTRATION_FINE_SCALES = (0.03125, 0.015625)
#: How many nearest surface vertices :func:`register_surface` looks at for the nearest
#: one facing the way the moving vertex faces (normals less than 90 degrees apart).  The
#: usual rule of non-rigid ICP (correspondences between surfaces facing apart are
#: dropped), here taking the next candidate instead.  Judged on three draws of 20 random
#: ICT pairs (``benchmarks/bench_clone_pairs.py --seed 2032 / 2033 / 1919``), against the
#: plain nearest vertex: the mean error lower or equal on all six targets (full 0.0471 ->
#: 0.0464, 0.0447 -> 0.0446, 0.0480 -> 0.0475 % IOD; decimated 0.0431 -> 0.0421, 0.0412
#: -> 0.0412, 0.0438 -> 0.0422), the worst pair's mean too, the median largest error
#: equal or lower (decimated 1919: 5.84 -> 5.63), the decimated targets' worst flips 8 ->
#: 5, 16 -> 15, 11 -> 11.
REGISTRATION_CANDIDATES = 8
#: The weight of the membrane term of :func:`register_surface` against its thin plate.
#: Measured on six ICT identity pairs (``benchmarks/bench_clone_ict.py --pairs``): 0.3,
#: 0.5 and 1 all lower the mean cloning error by 7-8 % against 0 (the thin plate alone);
#: 0.5 had the fewest errors over 2 % and no flipped triangle on the first pair.
REGISTRATION_MEMBRANE = 0.5


def _cotangent_laplacian(V: np.ndarray, T: np.ndarray) -> tuple:
    """(L, lumped vertex areas): the cotangent Laplacian, with negative cotangents
    (obtuse angles) and those of slivers clamped, so a decimated mesh's thin triangles
    can't make the operator indefinite or explode."""
    n = len(V)
    rows, cols, vals = [], [], []
    area = np.zeros(n)
    for k in range(3):
        i, j, o = T[:, k], T[:, (k + 1) % 3], T[:, (k + 2) % 3]
        a, b = V[i] - V[o], V[j] - V[o]
        cross = np.linalg.norm(np.cross(a, b), axis=1)
        cot = np.clip((a * b).sum(axis=1) / np.maximum(cross, 1e-300), 0.0, 1e3) / 2
        rows += [i, j]
        cols += [j, i]
        vals += [cot, cot]
        np.add.at(area, i, cross / 6)
    W = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, n))
    L = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    positive = area[area > 0]
    floor = positive.mean() * 1e-6 if len(positive) else 1.0
    return L.tocsr(), np.maximum(area, floor)


def _bilaplacian(V: np.ndarray, T: np.ndarray) -> tuple:
    """(Q, L, lumped vertex areas): ``Q = L' A^-1 L``, the discrete integral of the
    squared (cotangent) Laplacian ``L`` of a field over the mesh."""
    L, area = _cotangent_laplacian(V, T)
    return (L.T @ sp.diags(1.0 / area) @ L).tocsr(), L, area


class SPDFactoriser:
    """Factorises symmetric positive definite sparse matrices that share one sparsity
    pattern (the registration's system at each stiffness scale), returning a solver.

    The first matrix (or one of another pattern) is factorised by SuperLU with its
    minimum-degree ordering for symmetric matrices; that ordering is kept, and later
    matrices of the same pattern are permuted to it (one gather of their values into the
    permuted pattern, worked out once) and factorised in the natural order without
    pivoting (safe for SPD).  On the 16,696-row system of a 30,000-vertex pair that is
    0.11 s against 0.22 s per factorisation, with 25 % less fill.  No other solver we
    could install was faster (CHOLMOD built against Debian's SuiteSparse, cholespy,
    qdldl; figures in the README's cloning speed paragraph).

    >>> A = sp.csc_matrix(np.array([[4.0, 1, 0], [1, 3, 1], [0, 1, 2]]))
    >>> f = SPDFactoriser()
    >>> x1, x2 = f(A)(np.ones(3)), f(2 * A)(np.ones(3))
    >>> bool(np.allclose(A @ x1, 1)), bool(np.allclose(2 * A @ x2, 1)), f.reused
    (True, True, 1)
    >>> f(2 * A) is f(2 * A), f.reused       # a matrix met again: its solver again
    (True, 1)
    """

    def __init__(self) -> None:
        self._pattern: Optional[tuple] = None
        self._order: Optional[np.ndarray] = None
        #: how many factorisations reused the ordering
        self.reused = 0
        # the solvers of the last few matrices of the pattern, by their values: a
        # matrix met again (a second fit of the same mesh, or of its mirror image, at
        # the same scale) is not factorised again
        self._known: list = []

    def __call__(self, A: sp.spmatrix):
        A = sp.csc_matrix(A)
        A.sort_indices()
        pattern = (A.shape, A.indptr.tobytes(), A.indices.tobytes())
        if pattern == self._pattern:
            for data, solve in self._known:
                if np.array_equal(data, A.data):
                    return solve
        solve = self._factorise(A, pattern)
        self._known = [(A.data.copy(), solve)] + self._known[:7]
        return solve

    def _factorise(self, A: sp.csc_matrix, pattern: tuple):
        if pattern != self._pattern:
            self._known = []
            lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
            q = np.argsort(lu.perm_c)
            # the permuted pattern, and which of A's entries goes where in it: later
            # matrices are permuted by one gather of their values
            where = sp.csc_matrix((np.arange(1.0, A.nnz + 1), A.indices, A.indptr), shape=A.shape)
            where = where[q][:, q].tocsc()
            where.sort_indices()
            self._pattern, self._order = pattern, q
            self._permuted = (where.data.astype(np.int64) - 1, where.indices, where.indptr)
            return lu.solve
        q = self._order
        back = np.argsort(q)
        take, indices, indptr = self._permuted
        lu = spla.splu(sp.csc_matrix((A.data[take], indices, indptr), shape=A.shape),
                       permc_spec="NATURAL",
                       options={"SymmetricMode": True, "DiagPivotThresh": 0.0})
        self.reused += 1
        return lambda b: lu.solve(np.ascontiguousarray(np.asarray(b)[q]))[back]


def surface_biharmonic(vertices: np.ndarray, triangles: np.ndarray, fixed: np.ndarray,
                       values: np.ndarray) -> np.ndarray:
    """The smoothest field over the surface (least bilaplacian energy, cotangent weights)
    equal to ``values`` (k, d) at the vertices ``fixed`` (k,): the surface analogue of a
    thin-plate spline, so it follows the mesh round the neck and under the chin rather
    than through the air.  Vertices of a piece of the mesh holding no fixed vertex get 0.

    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [5, 0, 0], [6, 0, 0], [5, 1, 0]])
    >>> T = np.array([[0, 1, 3], [0, 3, 2], [4, 5, 6]])
    >>> (np.round(surface_biharmonic(V, T, np.array([0]), np.array([[2.0]])), 6) + 0.0).ravel().tolist()
    [2.0, 2.0, 2.0, 2.0, 0.0, 0.0, 0.0]
    """
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    fixed = np.asarray(fixed, dtype=np.int64)
    values = np.asarray(values, dtype=np.float64).reshape(len(fixed), -1)
    n = len(V)
    out = np.zeros((n, values.shape[1]))
    out[fixed] = values
    free = np.setdiff1d(np.arange(n), fixed)
    if not len(free) or not len(fixed):
        return out
    Q, _, _ = _bilaplacian(V, T)
    Qf = Q[free]
    Qff = Qf[:, free]
    # a whisper of pull towards 0 keeps pieces without a fixed vertex solvable
    eps = 1e-9 * float(Qff.diagonal().mean() or 1.0)
    solve = SPDFactoriser()(Qff + eps * sp.eye(len(free)))
    out[free] = solve(np.ascontiguousarray(-(Qf[:, fixed] @ values)))
    return out


def register_surface(rest: np.ndarray, triangles: np.ndarray, start: np.ndarray,
                     fixed: np.ndarray, surface_vertices: np.ndarray,
                     surface_triangles: np.ndarray, *,
                     scales: tuple = REGISTRATION_SCALES, iterations: int = 4,
                     membrane: float = REGISTRATION_MEMBRANE,
                     factorise: Optional[SPDFactoriser] = None) -> np.ndarray:
    """The vertices of a mesh (``rest`` (n, 3), ``triangles``) moved from ``start`` onto a
    surface, keeping the rows ``fixed`` where ``start`` has them: a non-rigid ICP.
    ``factorise``: an :class:`SPDFactoriser` to share with other fits of the same mesh
    (its fill-reducing order is found once).

    For each length scale l of ``scales`` in turn, ``iterations`` times: every vertex's
    nearest point on the surface is found, and the positions X minimise
    ``l**4 * |laplacian of D|**2 + membrane * l**2 * |gradient of D|**2 + |X - nearest|**2``
    with ``D = X - rest`` (all integrated over the mesh, cotangent weights and vertex
    areas), so X follows the surface while the displacement from ``rest`` stays smooth at
    scales above l.  Where the surface has a crease or a bend (under the chin, round the
    jaw) that pulls the neighbouring smooth stretches along, which a per-vertex closest
    point can't: it only moves a vertex across the surface, never along it.  The
    thin-plate term alone lets D stretch freely wherever it bends little; the membrane
    term resists that too (``membrane=0``: the thin plate alone; see
    :data:`REGISTRATION_MEMBRANE`).  The nearest points are the tangent-plane
    projections at the nearest surface vertex facing the same way (of the
    :data:`REGISTRATION_CANDIDATES` nearest; exact to second order in the mesh spacing,
    and a k-d tree query instead of a triangle search); a vertex with none stays put
    for that round.

    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); T = np.array([[0, 1, 3], [0, 3, 2]])
    >>> out = register_surface(V, T, V + [0.2, 0, 0.5], np.array([], dtype=int), V, T)
    >>> (np.round(out - V, 6) + 0.0).tolist()[0]   # onto the plane z=0, free to slide along it
    [0.2, 0.0, 0.0]
    >>> held = register_surface(V, T, V + [0, 0, 0.5], np.array([0]), V, T)
    >>> float(held[0, 2]), float(held[3, 2]) < 0.5      # held where it was; the rest pulled down
    (0.5, True)
    """
    R = np.asarray(rest, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    X = np.array(start, dtype=np.float64)
    n = len(R)
    used = np.zeros(n, dtype=bool)
    used[np.unique(T)] = True
    held = np.zeros(n, dtype=bool)
    held[np.asarray(fixed, dtype=np.int64)] = True
    free = np.flatnonzero(used & ~held)
    kept = np.flatnonzero(used & held)
    if not len(free) or not len(T):
        return X
    SV = np.asarray(surface_vertices, dtype=np.float64)
    ST = np.asarray(surface_triangles, dtype=np.int64).reshape(-1, 3)
    on = np.unique(ST)
    tree = cKDTree(SV[on])
    normals = vertex_normals(SV, ST)[on]
    bend, L, area = _bilaplacian(R, T)
    m = area[free]
    candidates = min(REGISTRATION_CANDIDATES, len(on))
    flip = None
    factorise = SPDFactoriser() if factorise is None else factorise
    # the free rows of both terms, cut out once for every scale
    Bf, Lf = bend[free], L[free]
    Bff, Bfk, Lff, Lfk = Bf[:, free], Bf[:, kept], Lf[:, free], Lf[:, kept]
    plate = Bff @ R[free] - Bfk @ (X[kept] - R[kept])
    stretch = Lff @ R[free] - Lfk @ (X[kept] - R[kept])
    mass = sp.diags(m)
    for scale in scales:
        # the energy of D = X - rest at this scale, l**4 (thin plate) + l**2 (membrane)
        a4, a2 = float(scale) ** 4, float(membrane) * float(scale) ** 2
        solve = factorise(a4 * Bff + a2 * Lff + mass)
        base = a4 * plate + a2 * stretch
        for _ in range(int(iterations)):
            # the nearest surface vertex facing the same way (of the few nearest): across
            # a closed mouth or eye the nearest is often on the other lip or lid
            Xf = X[free]
            own = vertex_normals(X, T)[free]
            _, k = tree.query(Xf)
            cos = np.einsum("ij,ij->i", normals[k], own)
            if flip is None:
                # a surface wound the other way round faces opposite throughout
                flip = bool(np.median(cos) < 0)
            lost = np.zeros(len(free), dtype=bool)
            away = np.flatnonzero((-cos if flip else cos) <= 0)
            if len(away) and candidates > 1:
                _, ks = tree.query(Xf[away], k=candidates)
                c = np.einsum("nkc,nc->nk", normals[ks], own[away])
                ok = (-c if flip else c) > 0
                k[away] = ks[np.arange(len(away)), np.argmax(ok, axis=1)]
                lost[away] = ~ok.any(axis=1)
            else:
                lost[away] = True
            p = SV[on[k]]
            nrm = normals[k]
            near = Xf - np.einsum("ij,ij->i", Xf - p, nrm)[:, None] * nrm
            # none facing the same way: the vertex is held where it is this round
            near[lost] = Xf[lost]
            rhs = base + m[:, None] * near
            X[free] = solve(np.ascontiguousarray(rhs))
    return X
