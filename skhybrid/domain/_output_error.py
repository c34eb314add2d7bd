"""The best linear approximation: an output-error model fitted by simulation.

:class:`_LinearOutputError` is the linear part of a block-structured model
(:class:`~skhybrid.domain.WienerHammersteinModel` starts from it) and the
physics of a system of which only the linear behaviour is known.
"""

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter, lfiltic
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from skhybrid.utils._docstrings import NO_NOISE_SIMULATE_OPTIONS, fill_doc
from skhybrid.utils._simulate_contract import SimulateContract

__all__ = []


@fill_doc(no_noise_simulate_options=NO_NOISE_SIMULATE_OPTIONS)
class _LinearOutputError(SimulateContract, BaseEstimator):
    """A linear output-error model ``y = B(q) / A(q) u + c`` fitted by simulation error.

    The physics a user writes for a block-structured system from its data sheet
    (the Wiener-Hammerstein benchmark: two linear filters around a static
    nonlinearity) when only the linear part is known: its best linear
    approximation. The fit starts from the one-step (ARX) least-squares
    solution and refines every coefficient by the free-run (output) error with
    :func:`scipy.optimize.least_squares`; the free run is
    :func:`scipy.signal.lfilter`, whose initial conditions come from the
    record's first measured samples (:func:`scipy.signal.lfiltic`), as a test
    record's free run starts from its initialisation window.

    Parameters
    ----------
    order : int, default=6
        Order of ``A(q)`` and ``B(q)`` (the number of states).
    max_nfev : int or None, default=50
        Most residual evaluations of the output-error refinement (0 keeps the
        ARX start).

    Attributes
    ----------
    b_ : ndarray of shape (n_inputs, order + 1)
        Numerator coefficients of each input (``b_0 u(t) + ... + b_n u(t-n)``).
    a_ : ndarray of shape (order + 1,)
        Denominator ``[1, a_1, ..., a_n]``.
    c_ : float
        Output offset.
    rmse_ : float
        Free-run RMSE over the fitted records.
    is_stable_ : bool
        Whether every pole lies inside the unit circle.
    """

    def __init__(self, order=6, max_nfev=50):
        self.order = order
        self.max_nfev = max_nfev

    def _records(self, inputs, outputs):
        several = isinstance(inputs, (list, tuple))
        U = [np.asarray(u, dtype=float) for u in (inputs if several else [inputs])]
        Y = [np.asarray(y, dtype=float) for y in (outputs if several else [outputs])]
        U = [u[:, None] if u.ndim == 1 else u for u in U]
        Y = [np.ravel(y) for y in Y]
        return U, Y

    def _arx(self, U, Y):
        n = self.order
        rows, targets = [], []
        for u, y in zip(U, Y, strict=True):
            T = len(y)
            lags = [-y[n - i : T - i] for i in range(1, n + 1)]
            for j in range(u.shape[1]):
                lags += [u[n - i : T - i, j] for i in range(n + 1)]
            rows.append(np.column_stack([*lags, np.ones(T - n)]))
            targets.append(y[n:])
        coef, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(targets), rcond=None)
        return coef

    def _unpack(self, theta, n_inputs):
        n = self.order
        a = np.concatenate([[1.0], theta[:n]])
        b = theta[n : n + n_inputs * (n + 1)].reshape(n_inputs, n + 1)
        # The ARX regression's constant is c * A(1); the model's offset is c.
        return a, b, float(theta[-1])

    def _run(self, a, b, c, u, y_init):
        """Free run over ``u`` from the measured ``y_init`` (its samples are kept)."""
        k, m = len(y_init), u.shape[1]
        y = np.empty(len(u))
        y[:k] = y_init
        if len(u) > k:
            # Each input's filter starts from the window; their outputs add up
            # (one shared denominator: the window's output is split evenly).
            past = (y_init[::-1] - c) / m
            y[k:] = c + sum(
                lfilter(b[j], a, u[k:, j], zi=lfiltic(b[j], a, past, u[:k, j][::-1]))[0]
                for j in range(m)
            )
        return y

    def fit(self, inputs, outputs):
        """Fit on one record or several: an ARX start, then the free-run error.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), or list of them
            The inputs of each record.
        outputs : array-like of shape (n_times,) or (n_times, 1), or list of them
            The measured output of each record.

        Returns
        -------
        self : _LinearOutputError
            The fitted model.
        """
        U, Y = self._records(inputs, outputs)
        n, m = self.order, U[0].shape[1]
        coef = self._arx(U, Y)
        a_sum = 1.0 + coef[:n].sum()
        theta0 = np.concatenate([coef[:-1], [coef[-1] / a_sum if a_sum else 0.0]])

        def residuals(theta):
            a, b, c = self._unpack(theta, m)
            parts = [
                (self._run(a, b, c, u, y[:n]) - y)[n:]
                for u, y in zip(U, Y, strict=True)
            ]
            r = np.concatenate(parts)
            return np.where(np.isfinite(r), r, 1e6)

        theta = theta0
        if self.max_nfev != 0 and np.all(np.abs(np.roots(np.r_[1.0, theta0[:n]])) < 1):
            # A trial step can make the filter unstable: its residuals are then
            # finite but so large that their squared sum overflows to inf in
            # least_squares, which rejects the step and shrinks its trust region.
            # That is how the fit handles it, not something to warn about.
            with np.errstate(over="ignore"):
                fit = least_squares(
                    residuals, theta0, max_nfev=self.max_nfev, x_scale="jac"
                )
            theta = fit.x
        self.a_, self.b_, self.c_ = self._unpack(theta, m)
        self.is_stable_ = bool(np.all(np.abs(np.roots(self.a_)) < 1))
        if not self.is_stable_:
            self.a_, self.b_, self.c_ = self._unpack(theta0, m)
        self.rmse_ = float(np.sqrt(np.mean(residuals(theta) ** 2)))
        self.n_inputs_ = m
        return self

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Free run from the measured initial window.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            Inputs over the whole record, initial window included.
        initial : array-like of shape (n_init, 1)
            Measured outputs of the first ``n_init >= order`` samples.
        init : {"measured"}, default="measured"
            Only ``"measured"``: the filter starts from the measured window.
        %(no_noise_simulate_options)s

        Returns
        -------
        outputs : ndarray of shape (n_times, 1)
            The first ``n_init`` samples are the measured ones.
        """
        check_is_fitted(self)
        if init != "measured" or n_samples is not None or return_std:
            raise ValueError(
                "_LinearOutputError simulates from the measured window only, "
                f"without noise; got init={init!r}, n_samples={n_samples!r}, "
                f"return_std={return_std!r}."
            )
        u = np.asarray(inputs, dtype=float)
        u = u[:, None] if u.ndim == 1 else u
        y_init = np.ravel(np.asarray(initial, dtype=float))
        if len(y_init) < self.order:
            raise ValueError(
                f"initial holds {len(y_init)} samples; the model needs at least "
                f"order={self.order}."
            )
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y_init))):
            raise ValueError("inputs and initial must be finite.")
        return self._run(self.a_, self.b_, self.c_, u, y_init)[:, None]
