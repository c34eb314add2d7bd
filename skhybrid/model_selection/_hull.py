"""Convex hull membership that stays exact and fast as the dimension grows.

``in_convex_hull`` decides, for every query point, whether it lies in the convex
hull of a reference set. Every answer rests on a certificate that is checked in
floating point:

* *inside*: a convex combination of reference points lies within ``tol`` of the
  point (a vertex of the reference set, a facet test, or the weights found by
  Wolfe's nearest-point algorithm or the HiGHS linear program);
* *outside*: a hyperplane separates the point from every reference point by
  more than ``tol`` (a bounding-box face, a facet, or the direction from the
  nearest point of the hull to the query).

Membership is invariant under affine maps, so the work is done on the reference
points centred on their mean, each feature divided by its range, and reduced to
their affine hull when they are flat.
"""

from numbers import Integral, Real

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, Delaunay, QhullError
from sklearn.utils import check_array
from threadpoolctl import ThreadpoolController

from skhybrid.utils._sklearn_compat import Interval, StrOptions, validate_params

__all__ = ["in_convex_hull"]

_METHODS = ("auto", "facets", "delaunay", "nearest_point", "lp")

# Above this many facets the facet test is not attempted by method="auto".
_AUTO_FACETS_MAX_DIM = 5
# Queries priced against the reference points at once: a (chunk, n_reference)
# float32 block of scores stays in cache.
_CHUNK = 512


@validate_params(
    {
        "points": ["array-like"],
        "reference": ["array-like"],
        "tol": [Interval(Real, 0, None, closed="left")],
        "method": [StrOptions(set(_METHODS))],
        "max_iter": [Interval(Integral, 1, None, closed="left"), None],
    },
    prefer_skip_nested_validation=True,
)
def in_convex_hull(points, reference, *, tol=1e-9, method="auto", max_iter=None):
    """Tell which points lie in the convex hull of the reference points.

    The answer is exact up to ``tol``: after each feature is centred on the mean
    of ``reference`` and divided by its range (``max - min`` over
    ``reference``), a point in the hull is reported inside and a point farther
    than ``tol`` (Euclidean distance) from the hull is reported outside; a point
    outside the hull but within ``tol`` of it may be reported either way. Convex
    hull membership does not change under this rescaling, so the tolerance is
    the only approximation.

    Parameters
    ----------
    points : array-like of shape (n_points, n_features)
        Query points.
    reference : array-like of shape (n_reference, n_features)
        Points whose convex hull is tested. Flat sets (all points on a line or
        a hyperplane, constant features) are handled by working in their
        affine hull.
    tol : float, default=1e-9
        Distance tolerance, in units of the feature ranges of ``reference``.
    method : {"auto", "facets", "delaunay", "nearest_point", "lp"}, \
            default="auto"
        How points that the cheap filters (bounding box, equality with a
        reference point, support in a few hundred directions) leave undecided
        are classified:

        - ``"facets"``: the facets of ``scipy.spatial.ConvexHull`` (Qhull);
          fast in low dimension, but the number of facets explodes beyond
          about 6 dimensions.
        - ``"delaunay"``: ``scipy.spatial.Delaunay(...).find_simplex`` on the
          hull vertices; for comparison, it is slower than ``"facets"``.
        - ``"nearest_point"``: Wolfe's nearest-point algorithm, run for many
          points at once with the pricing done as one matrix product; it ends
          with a certificate for nearly every point, and the few it leaves
          undecided get the exact linear program.
        - ``"lp"``: one HiGHS linear program (``scipy.optimize.linprog``) per
          point.
        - ``"auto"``: ``"facets"`` up to 5 dimensions (after reduction to the
          affine hull), ``"nearest_point"`` above.
    max_iter : int or None, default=None
        Major iterations of Wolfe's algorithm before a point is handed to the
        linear program; ``None`` means ``10 * (n_features + 1)``.

    Returns
    -------
    inside : ndarray of shape (n_points,), dtype=bool
        ``True`` where the point lies in the convex hull of ``reference``.

    See Also
    --------
    interpolation_extrapolation_split : Interpolative and extrapolative test
        sets built on this test.
    ConvexHullSplit : Cross-validation with test folds outside (or inside) the
        hull of the training fold.

    Notes
    -----
    A point ``x`` is inside when ``x = sum_i w_i r_i`` with ``w_i >= 0`` and
    ``sum_i w_i = 1`` over the reference points ``r_i``. Wolfe's algorithm
    [1]_ finds the point of the hull nearest to ``x`` through a short list of
    at most ``n_features + 1`` reference points. Each step prices all
    reference points against the current nearest point (a matrix product done
    for hundreds of queries at once), which also gives the separating
    hyperplane when ``x`` is outside. The algorithm is finite; for 25,000
    reference points in 16 dimensions it needs a few dozen steps per point,
    where a linear program per point (``method="lp"``) takes about a second.

    References
    ----------
    .. [1] P. Wolfe, "Finding the nearest point in a polytope", Mathematical
       Programming 11, 128-149 (1976).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.model_selection import in_convex_hull
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> in_convex_hull([[0.5, 0.5], [1.0, 1.0], [1.5, 0.5]], square)
    array([ True,  True, False])
    """
    points = check_array(points, dtype=np.float64, input_name="points")
    reference = check_array(reference, dtype=np.float64, input_name="reference")
    if points.shape[1] != reference.shape[1]:
        raise ValueError(
            f"points has {points.shape[1]} features but reference has "
            f"{reference.shape[1]}; both must describe the same features."
        )
    if max_iter is None:
        max_iter = 10 * (reference.shape[1] + 1)
    # Small problems run faster on one BLAS thread; idle threads of a
    # multithreaded BLAS spin and slow everything else on a busy machine.
    small = points.shape[0] * reference.shape[0] < 10_000_000
    with _blas_threads(1 if small else None):
        return _in_convex_hull(points, reference, tol, method, max_iter)


def _in_convex_hull(points, reference, tol, method, max_iter):

    inside = np.zeros(points.shape[0], dtype=bool)
    undecided = np.ones(points.shape[0], dtype=bool)

    # Points that are reference points are inside, whatever the method.
    is_vertex = _rows_in(points, reference)
    inside[is_vertex] = True
    undecided[is_vertex] = False

    Q, R, off, tol_in = _normalize(points, reference, tol)
    undecided &= off <= tol_in
    dim = R.shape[1]
    if dim == 0:  # all reference points coincide
        inside[undecided] = np.linalg.norm(Q[undecided], axis=1) <= tol_in
        return inside

    # Bounding box: a coordinate beyond the range by more than tol is a
    # separating hyperplane.
    lo, hi = R.min(axis=0), R.max(axis=0)
    undecided &= np.all((Q >= lo - tol_in) & (Q <= hi + tol_in), axis=1)
    if dim == 1:
        inside[undecided] = True
        return inside

    if method == "auto":
        method = "facets" if dim <= _AUTO_FACETS_MAX_DIM else "nearest_point"
    if method != "lp":
        undecided &= ~_support_outside(Q, R, tol_in, undecided)

    idx = np.flatnonzero(undecided)
    if idx.size == 0:
        return inside
    if method == "facets":
        inside[idx] = _facets(Q[idx], R, tol_in)
    elif method == "delaunay":
        inside[idx] = _delaunay(Q[idx], R, tol_in)
    elif method == "lp":
        inside[idx] = [_lp_inside(q, R, tol_in) for q in Q[idx]]
    else:
        inside[idx] = _nearest_point(Q[idx], R, tol_in, max_iter)
    return inside


def _rows_in(points, reference):
    """Mask of the rows of ``points`` that equal a row of ``reference``."""
    ref = {row.tobytes() for row in np.ascontiguousarray(reference + 0.0)}
    pts = np.ascontiguousarray(points + 0.0)  # + 0.0 turns -0.0 into 0.0
    return np.fromiter((row.tobytes() in ref for row in pts), bool, len(pts))


def _normalize(points, reference, tol):
    """Centre, scale and reduce both sets to the affine hull of ``reference``.

    Returns the queries and references in the reduced coordinates, the
    distance of each query from the affine hull, and the tolerance to use in
    the reduced coordinates.
    """
    center = reference.mean(axis=0)
    scale = np.ptp(reference, axis=0)
    scale[scale == 0] = 1.0
    R = (reference - center) / scale
    Q = (points - center) / scale
    _, s, vt = np.linalg.svd(R, full_matrices=False)
    rank = int(np.sum(s > s[0] * max(R.shape) * np.finfo(float).eps * 10))
    if s[0] == 0:
        rank = 0
    if rank == R.shape[1]:
        return Q, R, np.zeros(len(Q)), tol
    basis = vt[:rank].T
    Qr = Q @ basis
    off = np.linalg.norm(Q - Qr @ basis.T, axis=1)
    # Split the tolerance between the distance to the affine hull and the
    # distance within it, so that the total stays within tol.
    tol_in = tol / np.sqrt(2.0)
    return Qr, R @ basis, off, tol_in


def _support_outside(Q, R, tol, mask):
    """Outside certificates from the support of ``R`` in fixed directions."""
    dim = R.shape[1]
    rng = np.random.default_rng(0)
    D = rng.standard_normal((dim, 16 * dim))
    D /= np.linalg.norm(D, axis=0)
    h = (R @ D).max(axis=0)
    out = np.zeros(len(Q), dtype=bool)
    idx = np.flatnonzero(mask)
    out[idx] = np.any(Q[idx] @ D > h + tol, axis=1)
    return out


def _facets(Q, R, tol):
    """Facet test on the Qhull hull; near-facet points go to the LP."""
    hull = ConvexHull(R)
    A, b = hull.equations[:, :-1], hull.equations[:, -1]
    norms = np.linalg.norm(A, axis=1)
    inside = np.empty(len(Q), dtype=bool)
    unsure = np.zeros(len(Q), dtype=bool)
    for start in range(0, len(Q), 4 * _CHUNK):
        sl = slice(start, start + 4 * _CHUNK)
        dist = ((Q[sl] @ A.T + b) / norms).max(axis=1)
        # A facet distance above tol proves the point is farther than tol.
        # Inside every facet plane (up to Qhull's rounding) proves inside.
        inside[sl] = dist <= 1e3 * np.finfo(float).eps
        unsure[sl] = (dist > 1e3 * np.finfo(float).eps) & (dist <= tol)
    for i in np.flatnonzero(unsure):
        inside[i] = _lp_inside(Q[i], R, tol)
    return inside


def _delaunay(Q, R, tol):
    """Delaunay point location on the vertices of the hull."""
    try:
        vertices = R[ConvexHull(R).vertices]
    except QhullError:  # pragma: no cover - degenerate vertex set
        vertices = R
    tri = Delaunay(vertices)
    return tri.find_simplex(Q, tol=tol) >= 0


def _lp_inside(q, R, tol):
    """One HiGHS linear program: the L1 distance from ``q`` to the hull.

    ``min sum(s+ + s-)`` subject to ``R.T w + s+ - s- = q``, ``sum(w) = 1``,
    ``w, s+, s- >= 0``. The weights are checked against ``tol`` (Euclidean).
    """
    n, dim = R.shape
    A_eq = np.zeros((dim + 1, n + 2 * dim))
    A_eq[:dim, :n] = R.T
    A_eq[:dim, n : n + dim] = np.eye(dim)
    A_eq[:dim, n + dim :] = -np.eye(dim)
    A_eq[dim, :n] = 1.0
    c = np.r_[np.zeros(n), np.ones(2 * dim)]
    res = linprog(c, A_eq=A_eq, b_eq=np.r_[q, 1.0], bounds=(0, None), method="highs")
    if res.status != 0:  # pragma: no cover - the problem is always feasible
        raise RuntimeError(f"HiGHS failed on a hull membership LP: {res.message}")
    w = np.clip(res.x[:n], 0, None)
    w /= w.sum()
    if np.linalg.norm(w @ R - q) <= tol:
        return True
    # The L1 distance bounds the Euclidean one from above; HiGHS decides the
    # points that neither certificate settles (within its own tolerances).
    return bool(res.fun <= tol)


def _nearest_point(Q, R, tol, max_iter):
    """Wolfe's nearest-point algorithm for many queries at once."""
    inside, unsure = _wolfe(Q, R, tol, max_iter)
    for i in np.flatnonzero(unsure):
        inside[i] = _lp_inside(Q[i], R, tol)
    return inside


def _extreme_candidates(R, n_directions):
    """Indices of reference points that are extreme in random directions."""
    rng = np.random.default_rng(0)
    D = rng.standard_normal((n_directions, R.shape[1])).astype(np.float32)
    R32T = np.ascontiguousarray(R.T, dtype=np.float32)
    found = [np.argmax(D[s] @ R32T, axis=1) for s in _chunks(n_directions, _CHUNK)]
    return np.unique(np.concatenate(found))


def _chunks(n, size):
    return [slice(start, start + size) for start in range(0, n, size)]


_CONTROLLER = []


def _blas_threads(limit):
    """Context limiting the BLAS threads; the controller is built once."""
    if not _CONTROLLER:
        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=limit, user_api="blas")


def _price(z, R32):
    """Index and float32 value of ``argmin_r z . r`` for each row of ``z``."""
    j = np.empty(len(z), dtype=np.intp)
    smin = np.empty(len(z))
    z32 = z.astype(np.float32)
    # Small products run faster on one BLAS thread than on several.
    with _blas_threads(1 if len(z) < 4 * _CHUNK else None):
        for sl in _chunks(len(z), _CHUNK):
            scores = z32[sl] @ R32.T
            j[sl] = np.argmin(scores, axis=1)
            smin[sl] = scores[np.arange(len(j[sl])), j[sl]]
    return j, smin


def _wolfe(X, R, tol, max_iter):
    """Batched Wolfe iterations; returns (inside, undecided) masks.

    The corral of each query holds at most ``dim + 1`` atoms in ``B`` (atom
    minus query, zero in empty slots); slot weights ``lam`` are convex. The
    first atom is the centroid of ``R``, which is the origin and lies in the
    hull. Atoms are priced first against a candidate subset of the reference
    points (points extreme in random directions, and every atom any query has
    used); the whole set is priced only where the subset has nothing better
    to offer, which is also where an outside certificate must be checked.
    """
    m, dim = X.shape
    K = dim + 1
    eps = np.finfo(float).eps
    R32 = R.astype(np.float32)
    rnorm = np.sqrt((R * R).sum(axis=1).max())
    cand = _extreme_candidates(R, 64 * K)
    in_cand = np.zeros(len(R), dtype=bool)
    in_cand[cand] = True
    inside = np.zeros(m, dtype=bool)
    undecided = np.zeros(m, dtype=bool)
    B = np.zeros((m, K, dim))
    B[:, 0] = -X
    used = np.zeros((m, K), dtype=bool)
    used[:, 0] = True
    lam = np.zeros((m, K))
    lam[:, 0] = 1.0
    act = np.arange(m)
    for _ in range(max_iter):
        if act.size == 0:
            break
        z = np.einsum("qk,qkd->qd", lam[act], B[act])
        nz = np.linalg.norm(z, axis=1)
        nz2 = nz * nz
        done_in = nz <= tol
        inside[act[done_in]] = True
        bound = 4 * dim * np.finfo(np.float32).eps * nz * rnorm + 1e-300
        zx = np.einsum("qd,qd->q", z, X[act])
        # Price against the candidates; where they offer no improvement (or
        # would already separate), price against every reference point.
        jc, smin = _price(z, R32[cand])
        j = cand[jc]
        gap = smin - zx
        full = ~done_in & ((gap + bound > tol * nz) | (nz2 - gap <= 1e-9 * nz2 + bound))
        if full.any():
            j[full], smin_full = _price(z[full], R32)
            gap[full] = smin_full - zx[full]
            fresh = ~in_cand[j[full]]
            if fresh.any():
                new = np.unique(j[full][fresh])
                in_cand[new] = True
                cand = np.flatnonzero(in_cand)
        done_out = full & ((gap - bound) > tol * nz)
        # Near the decision, price again in float64.
        near = full & ~done_out & (gap + bound > tol * nz)
        if near.any():
            s64 = z[near] @ R.T
            j[near] = np.argmin(s64, axis=1)
            gap[near] = s64.min(axis=1) - zx[near]
            done_out[near] = gap[near] > tol * nz[near]
        # Wolfe's optimality test: no atom improves on z; stuck otherwise.
        stuck = full & ~done_out & (nz2 - gap <= 1e-12 * nz2 + bound)
        undecided[act[stuck]] = True
        keep = ~(done_in | done_out | stuck)
        act, j = act[keep], j[keep]
        if act.size == 0:
            break
        # Add the priced atom to a free slot.
        free = ~used[act]
        has_free = free.any(axis=1)
        undecided[act[~has_free]] = True
        act, j, free = act[has_free], j[has_free], free[has_free]
        slot = np.argmax(free, axis=1)
        B[act, slot] = R[j] - X[act]
        used[act, slot] = True
        lam[act, slot] = 0.0
        bad = _minor_cycles(B, used, lam, act, eps)
        undecided[act[bad]] = True
        act = act[~bad]
    undecided[act] = True
    # Verify the inside certificates from scratch.
    ins = np.flatnonzero(inside)
    z = np.einsum("qk,qkd->qd", lam[ins], B[ins])
    ok = (np.linalg.norm(z, axis=1) <= tol) & np.all(lam[ins] >= 0, axis=1)
    ok &= np.abs(lam[ins].sum(axis=1) - 1) <= 1e3 * eps
    undecided[ins[~ok]] = True
    inside[ins[~ok]] = False
    return inside, undecided


def _minor_cycles(B, used, lam, act, eps):
    """Move each corral to the affine minimiser with positive weights.

    Returns a mask over ``act`` of queries that failed (singular corrals or
    too many cycles); they go to the linear program.
    """
    K = B.shape[1]
    bad = np.zeros(act.size, dtype=bool)
    todo = np.arange(act.size)
    for _ in range(2 * K + 2):
        if todo.size == 0:
            break
        q = act[todo]
        Bq, u = B[q], used[q]
        G = np.einsum("qkd,qld->qkl", Bq, Bq)
        G[~u] = 0.0
        G.transpose(0, 2, 1)[~u] = 0.0
        M = np.zeros((len(q), K + 1, K + 1))
        M[:, :K, :K] = G
        ii = np.arange(K)
        M[:, ii, ii] += np.where(u, 0.0, 1.0)
        M[:, :K, K] = u
        M[:, K, :K] = u
        rhs = np.zeros((len(q), K + 1))
        rhs[:, K] = 1.0
        try:
            sol = np.linalg.solve(M, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:
            sol = np.einsum("qij,qj->qi", np.linalg.pinv(M), rhs)
        alpha = np.where(u, sol[:, :K], 0.0)
        finite = np.all(np.isfinite(alpha), axis=1)
        positive = np.all(~u | (alpha > 1e-12), axis=1) & finite
        lam[q[positive]] = alpha[positive]
        bad[todo[~finite]] = True
        move = ~positive & finite
        if not move.any():
            todo = todo[:0]
            break
        qm, a, lm, um = q[move], alpha[move], lam[q[move]], u[move]
        neg = um & (a <= 1e-12)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(neg, lm / (lm - a), np.inf)
        k = np.argmin(ratio, axis=1)
        theta = np.clip(ratio[np.arange(len(qm)), k], 0.0, 1.0)
        new = theta[:, None] * a + (1 - theta[:, None]) * lm
        new[np.arange(len(qm)), k] = 0.0
        drop = um & (new <= 1e-15)
        new[drop] = 0.0
        new /= new.sum(axis=1, keepdims=True)
        lam[qm] = new
        um = um & ~drop
        used[qm] = um
        B[qm] = np.where(um[..., None], B[qm], 0.0)
        todo = todo[move]
    bad[todo] = True
    return bad
