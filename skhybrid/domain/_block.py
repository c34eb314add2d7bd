"""WienerHammersteinModel: two linear filters around a static nonlinearity."""

import itertools
import warnings
from numbers import Integral

import numpy as np
from scipy.interpolate import BSpline
from scipy.optimize import least_squares
from scipy.signal import lfilter
from sklearn.base import BaseEstimator
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils.validation import check_is_fitted

from skhybrid.domain._identifiability import warn_if_underdetermined
from skhybrid.domain._output_error import _LinearOutputError
from skhybrid.simulation import (
    check_trajectories,
    fit_initial_states,
    pack_trajectories,
)
from skhybrid.utils._docstrings import RECORD_MODEL_DOCS, fill_doc
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._simulate_checks import check_simulate_options
from skhybrid.utils._simulate_contract import SimulateContract
from skhybrid.utils._sklearn_compat import Interval, _fit_context
from skhybrid.utils._transaction import TransactionalFitMixin
from skhybrid.utils._validation import validate_records

__all__ = ["WienerHammersteinModel"]

#: Most pole/zero splits :meth:`WienerHammersteinModel.fit` scans.
MAX_SPLITS = 4096
#: A filter's memory: the samples for its slowest pole to decay to this fraction.
MEMORY_DECAY = 1e-3
#: The share of ``max_nfev`` each split's first refinement gets (the best split
#: then goes on with the rest): a half. A fifth ranked the splits wrongly on
#: some of the Wiener-Hammerstein benchmark's folds (``benchmarks/LOG.md``).
SHORT_SHARE = 2
#: Largest residual of the fit: a non-finite simulated sample counts as this.
NON_FINITE_RESIDUAL = 1e6


def _groups(roots):
    """Split roots into groups a real filter keeps together: reals, conjugate pairs."""
    roots = list(roots)
    used = [False] * len(roots)
    out = []
    for i, z in enumerate(roots):
        if used[i]:
            continue
        used[i] = True
        if abs(z.imag) > 1e-8 * max(1.0, abs(z)):
            rest = [k for k in range(len(roots)) if not used[k]]
            j = min(rest, key=lambda k: abs(roots[k] - np.conj(z)))
            used[j] = True
            out.append([z, roots[j]])
        else:
            out.append([z.real])
    return out


def _polynomial(roots):
    """Real coefficients (``[1, ...]``) of the monic polynomial with these roots."""
    return np.real(np.poly(roots)) if len(roots) else np.array([1.0])


def _memory(a):
    """Samples for the slowest pole of ``1 / a(q)`` to decay by :data:`MEMORY_DECAY`."""
    radius = np.max(np.abs(np.roots(a)), initial=0.0)
    if radius <= 0:
        return 1
    if radius >= 1:
        return np.iinfo(np.int64).max
    return int(np.ceil(np.log(MEMORY_DECAY) / np.log(radius)))


def _is_stable(a):
    return bool(np.all(np.abs(np.roots(a)) < 1))


def _bounded(r):
    """Residuals with a run that blows up made large and finite, not inf or NaN."""
    r = np.where(np.isfinite(r), r, NON_FINITE_RESIDUAL)
    return np.clip(r, -NON_FINITE_RESIDUAL, NON_FINITE_RESIDUAL)


def _delayed(z, k):
    """``z`` delayed by ``k`` samples along its first axis (zeros before)."""
    if k == 0:
        return z
    out = np.zeros_like(z)
    out[k:] = z[:-k]
    return out


def _sensitivities(a1, b1, a2, b2, coef, knots, u, free_b2):
    """Free run over ``u`` from rest and its derivatives in the refined coefficients.

    Forward-mode differentiation of the block model, one pass over the record:
    each derivative of a filter's output is itself a filtered signal (the
    derivative of ``x = B1(q) / A1(q) u`` in ``a1[k]`` is ``-q^-k / A1(q) x``,
    in ``b1[j, k]`` ``q^-k / A1(q) u_j``), carried through the spline by its
    slope and through ``G2`` by one more filter. Every column is filtered at
    once (``lfilter`` along the time axis), so the Jacobian costs a few free
    runs, not one per coefficient.

    Returns
    -------
    y : ndarray of shape (n_times,)
        The free run, as :meth:`WienerHammersteinModel._run` gives it.
    J : ndarray of shape (n_times, n_coefficients)
        Its derivatives in the order of the refinement's vector: ``a1[1:]``,
        ``b1`` (row by row), ``a2[1:]``, ``b2[free_b2]``, ``coef``.
    """
    n1, n2 = len(a1) - 1, len(a2) - 1
    lo, hi = knots[3], knots[-4]
    with np.errstate(all="ignore"):
        x = WienerHammersteinModel._first_filter(a1, b1, u)
        x_past = lfilter([1.0], a1, x)
        w = lfilter([1.0], a1, u, axis=0)
        dx = [-_delayed(x_past, k) for k in range(1, n1 + 1)]
        dx += [
            _delayed(w[:, j], k) for j in range(b1.shape[0]) for k in range(b1.shape[1])
        ]
        inside = np.clip(x, lo, hi)
        spline = BSpline(knots, coef, 3)
        slope = spline.derivative()(inside)  # the linear continuation's too
        v = WienerHammersteinModel._nonlinearity(x, knots, coef)
        # The spline's value in each coefficient: its basis at x, continued
        # linearly beyond the end knots as the spline is.
        basis = BSpline.design_matrix(inside, knots, 3).toarray()
        basis_slope = BSpline(knots, np.eye(len(coef)), 3).derivative()
        basis += np.where(x < lo, x - lo, 0.0)[:, None] * basis_slope(lo)[None, :]
        basis += np.where(x > hi, x - hi, 0.0)[:, None] * basis_slope(hi)[None, :]
        y = lfilter(b2, a2, v)
        v_past, y_past = lfilter([1.0], a2, v), lfilter([1.0], a2, y)
        inner = np.column_stack([slope[:, None] * np.column_stack(dx), basis])
        inner = lfilter(b2, a2, inner, axis=0)
        columns = [inner[:, : len(dx)]]
        columns += [-_delayed(y_past, k)[:, None] for k in range(1, n2 + 1)]
        columns += [_delayed(v_past, int(k))[:, None] for k in free_b2]
        columns.append(inner[:, len(dx) :])
    return y, np.concatenate(columns, axis=1)


@fill_doc(**RECORD_MODEL_DOCS)
class WienerHammersteinModel(
    SimulateContract, TransactionalFitMixin, VersionedPickleMixin, BaseEstimator
):
    """Two linear filters around a static nonlinearity, started from the linear fit.

    The block structure of many electronic and mechanical systems: the inputs
    pass a linear filter ``G1``, a static (memoryless) nonlinearity ``f`` and a
    second linear filter ``G2``::

        x(t) = sum_j B1_j(q) / A1(q) u_j(t),   y(t) = B2(q) / A2(q) f(x(t))

    ``f`` is a cubic spline with ``n_knots`` equally spaced knots over the
    range of ``x`` in the data, continued linearly beyond it. A Wiener model
    (``G2 = 1``) and a Hammerstein model (``G1 = 1``) are the special cases
    where all poles and zeros sit in one filter.

    Such a model is fitted in the way of Sjoberg, Lauwers & Schoukens (2012):

    1. the best linear approximation (BLA) of the system, a linear
       output-error model of ``order`` poles and zeros fitted by simulation
       error, whose poles and zeros are the two filters' together;
    2. every split of the BLA's poles and zeros between ``G1`` and ``G2``
       (real roots and complex-conjugate pairs move as one), each scored by
       the nonlinearity fitted to it by linear least squares (``f``'s spline
       coefficients enter the output linearly once both filters are fixed),
       on at most ``scan_samples`` samples;
    3. the ``n_starts`` best splits refined, every coefficient of both filters
       and of the spline together, by the free-run (output) error with
       :func:`scipy.optimize.least_squares` and an exact Jacobian (forward-mode
       sensitivities through the filters); each split first for half of
       ``max_nfev`` evaluations, then the best of them for the rest; the
       refined model with the lowest error on the fitted records is kept.

    A single local refinement from the BLA rarely finds the global optimum:
    which split is right only shows once the nonlinearity is fitted, and the
    best split before refinement need not be the best after it.

    In the fit the filters start at rest at a record's first sample, and the
    first ``transient`` samples of each record (by default the BLA's memory:
    the samples its slowest pole takes to decay by 1e-3) are left out.
    :meth:`simulate` starts them at rest too (make the initial window at least
    ``memory_`` samples long), or with ``init="least_squares"`` from the
    initial states that match the measured window best; it returns the
    measured window in place of the model's first samples.

    Parameters
    ----------
    order : int, default=6
        Number of poles (and of zeros) of the best linear approximation, shared
        out between the two filters.
    n_knots : int, default=20
        Knots of the nonlinearity's cubic spline, ends included (``n_knots +
        2`` coefficients).
    n_starts : int, default=4
        Best-scoring splits refined by the free-run error.
    max_nfev : int, default=200
        Most residual evaluations of the best split's refinement, half of
        them for each split's first one (0 keeps the scanned
        splits' linear fits).
    transient : int or None, default=None
        Samples at the start of each record left out of the fit; None uses the
        BLA's memory (at most a quarter of the shortest record).
    scan_samples : int, default=20000
        Most samples of the records (the first of each, in proportion) on which
        the splits are scanned.

    Attributes
    ----------
    a1_, a2_ : ndarray of shape (n_poles_1 + 1,) and (n_poles_2 + 1,)
        Denominators ``[1, ...]`` of ``G1`` and ``G2``.
    b1_ : ndarray of shape (n_inputs, n_zeros_1 + 1)
        Numerators of ``G1``, one row per input.
    b2_ : ndarray of shape (n_zeros_2 + 1,)
        Numerator of ``G2``.
    knots_ : ndarray of shape (n_knots + 6,)
        Knot vector of the spline (its ends repeated three times).
    spline_coef_ : ndarray of shape (n_knots + 2,)
        Coefficients of the spline ``f``.
    bla_ : object
        The best linear approximation: ``a_`` (denominator), ``b_`` (numerators,
        one row per input), ``c_`` (output offset) and ``rmse_``.
    splits_ : list of dict
        The refined splits, best first: ``poles_1`` and ``zeros_1`` (the roots
        in ``G1``; the others are in ``G2``), ``scan_rmse`` (the linear fit of
        ``f`` on the scanned samples), ``rmse`` (after refinement, over the
        fitted records) and ``nfev``.
    n_splits_ : int
        Number of splits scanned.
    rmse_ : float
        Free-run RMSE over the fitted records (their transients left out).
    memory_ : int
        Samples for the slowest pole of either filter to decay by 1e-3.
    transient_ : int
        Samples left out at the start of each record.
    n_features_in_ : int
        Number of inputs.

    See Also
    --------
    skhybrid.domain.StateSpaceModel : A physics model of its own equations.

    References
    ----------
    J. Sjoberg, L. Lauwers, J. Schoukens, "Identification of Wiener-Hammerstein
    models: two algorithms based on the best split of a linear model applied to
    the SYSID'09 benchmark problem", Control Engineering Practice 20(11), 2012.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from skhybrid.domain import WienerHammersteinModel
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=3000)
    >>> x = lfilter([0.0, 0.5], [1.0, -0.5], u)
    >>> y = lfilter([0.0, 0.3], [1.0, -0.7], np.tanh(x))
    >>> model = WienerHammersteinModel(order=2, n_knots=8).fit(u[:, None], y)
    >>> y_sim = model.simulate(u[:, None], y[:20])
    >>> bool(np.sqrt(np.mean((y_sim - y[:, None]) ** 2)) < 1e-3)
    True
    """

    _parameter_constraints = {
        "order": [Interval(Integral, 1, None, closed="left")],
        "n_knots": [Interval(Integral, 2, None, closed="left")],
        "n_starts": [Interval(Integral, 1, None, closed="left")],
        "max_nfev": [Interval(Integral, 0, None, closed="left")],
        "transient": [Interval(Integral, 0, None, closed="left"), None],
        "scan_samples": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(
        self,
        order=6,
        *,
        n_knots=20,
        n_starts=4,
        max_nfev=200,
        transient=None,
        scan_samples=20000,
    ):
        self.order = order
        self.n_knots = n_knots
        self.n_starts = n_starts
        self.max_nfev = max_nfev
        self.transient = transient
        self.scan_samples = scan_samples

    # -- data ----------------------------------------------------------------------
    def _records(self, X, y):
        """Validated ``(inputs, outputs)`` records: one record or a list of them."""
        U, Y = validate_records(self, X, y)
        for y_i in Y:
            if y_i.shape[1] != 1:
                raise ValueError(
                    f"WienerHammersteinModel models one output; y has "
                    f"{y_i.shape[1]} columns."
                )
            shortest = 2 * (self.order + 1)
            if len(y_i) < shortest:
                raise ValueError(
                    f"WienerHammersteinModel(order={self.order}) needs records of "
                    f"at least {shortest} samples; got {len(y_i)} sample(s)."
                )
        return U, [np.ravel(y_i) for y_i in Y]

    # -- the model -----------------------------------------------------------------
    @staticmethod
    def _nonlinearity(x, knots, coef):
        """The spline ``f(x)``, continued linearly beyond its end knots."""
        lo, hi = knots[3], knots[-4]
        spline = BSpline(knots, coef, 3)
        inside = np.clip(x, lo, hi)
        v = spline(inside)
        below, above = x < lo, x > hi
        if below.any() or above.any():
            slope = spline.derivative()
            v = v + np.where(below, slope(lo) * (x - lo), 0.0)
            v = v + np.where(above, slope(hi) * (x - hi), 0.0)
        return v

    @staticmethod
    def _first_filter(a1, b1, u):
        return sum(lfilter(b1[j], a1, u[:, j]) for j in range(u.shape[1]))

    def _run(self, a1, b1, a2, b2, coef, knots, u):
        """Free run of the block model over the inputs ``u``, from rest."""
        with np.errstate(all="ignore"):
            x = self._first_filter(a1, b1, u)
            return lfilter(b2, a2, self._nonlinearity(x, knots, coef))

    # -- the split scan ------------------------------------------------------------
    def _splits(self, bla, n_inputs):
        """Every ``(poles_1, zeros_1, poles_2, zeros_2)`` split of the BLA's roots.

        Unstable poles are mirrored into the unit circle first. With several
        inputs every numerator stays in ``G1`` (their zeros differ).
        """
        poles = np.roots(bla.a_)
        poles = np.where(np.abs(poles) >= 1, 1 / np.conj(poles), poles)
        pole_groups = _groups(poles)
        zero_groups = _groups(np.roots(bla.b_[0])) if n_inputs == 1 else []
        n_splits = 2 ** (len(pole_groups) + len(zero_groups))
        if n_splits > MAX_SPLITS:
            raise ValueError(
                f"order={self.order} gives {n_splits} pole/zero splits to scan, more "
                f"than {MAX_SPLITS}; lower the order."
            )
        for pm in itertools.product((0, 1), repeat=len(pole_groups)):
            for zm in itertools.product((0, 1), repeat=len(zero_groups)):
                yield tuple(
                    [
                        r
                        for g, k in zip(groups, mask, strict=True)
                        if k == side
                        for r in g
                    ]
                    for side in (0, 1)
                    for groups, mask in ((pole_groups, pm), (zero_groups, zm))
                )

    def _split_filters(self, bla, split, u_scan):
        """Both filters of a split, ``G1`` scaled to a unit-variance output."""
        poles_1, zeros_1, poles_2, zeros_2 = split
        a1, a2 = _polynomial(poles_1), _polynomial(poles_2)
        if bla.b_.shape[0] == 1:
            b1 = _polynomial(zeros_1)[None, :]
            b2 = _polynomial(zeros_2)
        else:
            b1, b2 = bla.b_.copy(), np.array([1.0])
        x = self._first_filter(a1, b1, u_scan)
        scale = np.std(x)
        b1 = b1 / scale if np.isfinite(scale) and scale > 0 else b1
        b2 = b2 / np.max(np.abs(b2))
        return a1, b1, a2, b2

    def _linear_fit(self, filters, U, Y, transient):
        """The spline's knots and coefficients by linear least squares, and the RMSE."""
        a1, b1, a2, b2 = filters
        X = [self._first_filter(a1, b1, u) for u in U]
        lo = min(np.min(x) for x in X)
        hi = max(np.max(x) for x in X)
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            return None, None, np.inf
        inner = np.linspace(lo, hi, self.n_knots)
        knots = np.r_[[lo] * 3, inner, [hi] * 3]
        rows, targets = [], []
        for x, y in zip(X, Y, strict=True):
            design = BSpline.design_matrix(np.clip(x, lo, hi), knots, 3).toarray()
            filtered = lfilter(b2, a2, design, axis=0)
            rows.append(filtered[transient:])
            targets.append(y[transient:])
        rows, targets = np.vstack(rows), np.concatenate(targets)
        coef, *_ = np.linalg.lstsq(rows, targets, rcond=None)
        rmse = float(np.sqrt(np.mean((rows @ coef - targets) ** 2)))
        return knots, coef, rmse if np.isfinite(rmse) else np.inf

    # -- refinement ----------------------------------------------------------------
    def _refine(self, filters, knots, coef, U, Y, transient, max_nfev=None):
        """Every coefficient by the free-run error; returns the parameters and fit.

        At most ``max_nfev`` residual evaluations (None: the model's).
        """
        max_nfev = self.max_nfev if max_nfev is None else max_nfev
        a1, b1, a2, b2 = filters
        n1, n2 = len(a1) - 1, len(a2) - 1
        # G2's largest numerator coefficient stays fixed: scaling G2 against the
        # spline would otherwise leave the problem one direction short of rank.
        fixed = int(np.argmax(np.abs(b2)))
        free_b2 = np.delete(np.arange(len(b2)), fixed)

        def unpack(theta):
            i = 0
            a1_ = np.r_[1.0, theta[i : i + n1]]
            i += n1
            b1_ = theta[i : i + b1.size].reshape(b1.shape)
            i += b1.size
            a2_ = np.r_[1.0, theta[i : i + n2]]
            i += n2
            b2_ = b2.copy()
            b2_[free_b2] = theta[i : i + len(free_b2)]
            i += len(free_b2)
            return a1_, b1_, a2_, b2_, theta[i:]

        def residuals(theta):
            parts = [
                (self._run(*unpack(theta), knots, u) - y)[transient:]
                for u, y in zip(U, Y, strict=True)
            ]
            return _bounded(np.concatenate(parts))

        def jacobian(theta):
            a1_, b1_, a2_, b2_, coef_ = unpack(theta)
            parts = []
            for u, y in zip(U, Y, strict=True):
                out, J = _sensitivities(a1_, b1_, a2_, b2_, coef_, knots, u, free_b2)
                r = (out - y)[transient:]
                J = J[transient:]
                # Where the residual is bounded (a run that blows up) it does
                # not move with the parameters.
                J[~(np.abs(r) < NON_FINITE_RESIDUAL)] = 0.0
                parts.append(J)
            J = np.concatenate(parts)
            return np.where(np.isfinite(J), J, 0.0)

        theta0 = np.concatenate([a1[1:], b1.ravel(), a2[1:], b2[free_b2], coef])
        if max_nfev == 0:
            r = residuals(theta0)
            return unpack(theta0), float(np.sqrt(np.mean(r**2))), 0, False
        n_residuals = sum(len(y) - transient for y in Y)
        method = "lm" if n_residuals >= len(theta0) else "trf"
        fit = least_squares(
            residuals,
            theta0,
            jac=jacobian,
            method=method,
            x_scale="jac",
            max_nfev=max_nfev,
        )
        params = unpack(fit.x)
        if not (_is_stable(params[0]) and _is_stable(params[2])):
            # A refinement that leaves the stable filters is not used.
            r = residuals(theta0)
            return unpack(theta0), float(np.sqrt(np.mean(r**2))), fit.nfev, False
        rmse = float(np.sqrt(np.mean(fit.fun**2)))
        return params, rmse, fit.nfev, fit.status == 0

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Fit on one record or several: the BLA, the split scan, the refinements.

        Parameters
        ----------
        %(records_x)s
        y : array-like of shape (n_times,) or (n_times, 1), or list of them
            The measured output of each record.

        Returns
        -------
        self : WienerHammersteinModel
            The fitted model.
        """
        U, Y = self._records(X, y)
        bla = _LinearOutputError(order=self.order).fit(U, Y)
        shortest = min(len(y_i) for y_i in Y)
        if self.transient is None:
            transient = min(_memory(bla.a_), shortest // 4)
        elif self.transient >= shortest:
            raise ValueError(
                f"transient={self.transient} must be smaller than the shortest "
                f"record ({shortest} samples)."
            )
        else:
            transient = self.transient

        total = sum(len(y_i) for y_i in Y)
        share = min(1.0, self.scan_samples / total)
        lengths = [
            max(int(len(y_i) * share), min(len(y_i), 2 * transient + 1)) for y_i in Y
        ]
        U_scan = [u_i[:n] for u_i, n in zip(U, lengths, strict=True)]
        Y_scan = [y_i[:n] for y_i, n in zip(Y, lengths, strict=True)]

        scanned = []
        for split in self._splits(bla, U[0].shape[1]):
            filters = self._split_filters(bla, split, np.vstack(U_scan))
            knots, coef, rmse = self._linear_fit(filters, U_scan, Y_scan, transient)
            scanned.append((rmse, split, filters))
        scanned.sort(key=lambda item: item[0])

        # Each split is refined briefly, the best of them to the end: the
        # splits' errors part early (the right one is often ten times lower),
        # and the others would spend the budget in their own valleys.
        several = min(self.n_starts, len(scanned)) > 1 and self.max_nfev > 0
        short = max(1, self.max_nfev // SHORT_SHARE) if several else self.max_nfev
        refined = []
        for scan_rmse, split, filters in scanned[: self.n_starts]:
            knots, coef, _ = self._linear_fit(filters, U, Y, transient)
            if knots is None:
                continue
            params, rmse, nfev, stopped = self._refine(
                filters, knots, coef, U, Y, transient, max_nfev=short
            )
            refined.append(
                {
                    "poles_1": np.asarray(split[0]),
                    "zeros_1": np.asarray(split[1]),
                    "scan_rmse": scan_rmse,
                    "rmse": rmse,
                    "nfev": nfev,
                    "_params": (*params, knots),
                    "_stopped": stopped,
                }
            )
        refined.sort(key=lambda item: item["rmse"])
        if refined and refined[0]["_stopped"] and short < self.max_nfev:
            best = refined[0]
            *filters, coef, knots = best["_params"]
            params, rmse, nfev, stopped = self._refine(
                filters, knots, coef, U, Y, transient, self.max_nfev - short
            )
            if rmse <= best["rmse"]:
                best.update(rmse=rmse, _params=(*params, knots), _stopped=stopped)
            best["nfev"] += nfev
            refined.sort(key=lambda item: item["rmse"])
        if not refined or not np.isfinite(refined[0]["rmse"]):
            raise ValueError(
                "No split of the best linear approximation gave a finite fit; the "
                "data may not suit a Wiener-Hammerstein model of "
                f"order={self.order}."
            )
        best = refined[0]
        a1, b1, a2, b2, coef, _ = best["_params"]
        warn_if_underdetermined(
            self,
            sum(len(y_i) - transient for y_i in Y),
            # The refinement's free vector (G2's largest coefficient is fixed).
            len(a1) - 1 + b1.size + len(a2) - 1 + len(b2) - 1 + len(coef),
            remedy="a lower order or fewer n_knots",
        )
        if best["_stopped"] and self.max_nfev > 0:
            warnings.warn(
                f"WienerHammersteinModel's refinement stopped at max_nfev="
                f"{self.max_nfev} before converging; raise max_nfev.",
                ConvergenceWarning,
                stacklevel=2,
            )
        (self.a1_, self.b1_, self.a2_, self.b2_, self.spline_coef_, self.knots_) = best[
            "_params"
        ]
        self.splits_ = [
            {k: v for k, v in item.items() if not k.startswith("_")} for item in refined
        ]
        self.n_splits_ = len(scanned)
        self.bla_ = bla
        self.rmse_ = best["rmse"]
        self.transient_ = transient
        self.memory_ = max(_memory(self.a1_), _memory(self.a2_))
        return self

    def _free_responses(self, n_times):
        """Free responses ``(n_times, n1 + n2)`` of the two filters' initial states.

        Column ``k < n1`` is the first filter's output from its ``k``-th initial
        state alone (inputs zero), which adds to ``x``; the others are the
        second filter's, which add to ``y``.
        """
        n1, n2 = len(self.a1_) - 1, len(self.a2_) - 1
        zeros = np.zeros(n_times)
        columns = [
            lfilter([1.0], a, zeros, zi=np.eye(n)[k])[0]
            for a, n in ((self.a1_, n1), (self.a2_, n2))
            for k in range(n)
        ]
        return np.column_stack(columns) if columns else np.zeros((n_times, 0))

    def _run_from(self, u, z):
        """Free run over ``u`` from the filters' initial states ``z`` (rest: zeros)."""
        n1 = len(self.a1_) - 1
        free = self._free_responses(len(u)) if len(z) else None
        with np.errstate(all="ignore"):
            x = self._first_filter(self.a1_, self.b1_, u)
            if free is not None:
                x = x + free[:, :n1] @ z[:n1]
            y = lfilter(
                self.b2_,
                self.a2_,
                self._nonlinearity(x, self.knots_, self.spline_coef_),
            )
            if free is not None:
                y = y + free[:, n1:] @ z[n1:]
        return y

    def _initial_states(self, U_list, Y_list):
        """The filters' initial states whose run matches each measured window best."""
        n_states = len(self.a1_) + len(self.a2_) - 2
        if n_states == 0:
            return np.zeros((len(U_list), 0))

        def residuals(Z, index):
            return np.stack(
                [
                    self._run_from(U_list[i][: len(Y_list[i])], z) - Y_list[i][:, 0]
                    for z, i in zip(Z, index, strict=True)
                ]
            )

        out = np.zeros((len(U_list), n_states))
        # One batch per window length (the solver's residuals have one width).
        for n_init in {len(y) for y in Y_list}:
            idx = [i for i, y in enumerate(Y_list) if len(y) == n_init]
            z, _ = fit_initial_states(
                lambda Z, index, idx=idx: residuals(Z, [idx[i] for i in index]),
                np.zeros((len(idx), n_states)),
            )
            out[idx] = z
        return out

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Free run over whole records, each measured initial window returned as is.

        Parameters
        ----------
        %(record_inputs)s
        initial : array-like of shape (n_init, 1), (n_trajectories, n_init, 1) \
or list of 2-D arrays
            Measured outputs of each record's first ``n_init`` samples.
        init : {"measured", "least_squares"}, default="measured"
            ``"measured"``: both filters start at rest at the record's first
            sample (make ``n_init`` at least ``memory_`` so that the start has
            died out by the window's end). ``"least_squares"``: they start from
            the initial states whose run through the window matches its
            measured outputs best (:func:`~skhybrid.simulation.fit_initial_states`).
        %(no_noise_simulate_options)s

        Returns
        -------
        outputs : ndarray or list of ndarray
            Simulated outputs ``(n_times, 1)`` in the container form of
            ``inputs``; each record's first ``n_init`` are the measured ones.
        """
        check_is_fitted(self)
        check_simulate_options(self, init, n_samples, return_std)
        U_list, Y_list, form = check_trajectories(inputs, initial)
        if U_list[0].shape[1] != self.n_features_in_:
            raise ValueError(
                f"inputs has {U_list[0].shape[1]} columns; the model was fitted on "
                f"{self.n_features_in_}."
            )
        if Y_list[0].shape[1] != 1:
            raise ValueError(
                f"initial has {Y_list[0].shape[1]} columns; the model has one output."
            )
        n_states = len(self.a1_) + len(self.a2_) - 2
        if init == "least_squares":
            Z = self._initial_states(U_list, Y_list)
        else:
            Z = np.zeros((len(U_list), n_states))
        lengths = np.array([len(u) for u in U_list])
        out = np.zeros((len(U_list), lengths.max(), 1))
        for i, (u, y0) in enumerate(zip(U_list, Y_list, strict=True)):
            out[i, : len(u), 0] = self._run_from(u, Z[i])
            out[i, : len(y0)] = y0
        return pack_trajectories(out, lengths, form)
