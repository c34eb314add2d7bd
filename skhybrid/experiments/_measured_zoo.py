"""The model zoo of the measured benchmarks and its choice on the validation tail.

Every model is fitted on the estimation record only. Choices (window lengths,
the horizon ``T`` and the architecture of the state-space hybrid, and the model
to quote) are made on its validation tail, the last 25 %: a candidate is fitted
on the first 75 % and simulated in free run over the tail from the tail's first
``n_init`` measured outputs, as the official protocol simulates a test record.
"""

import itertools
import time
import warnings

import numpy as np
from sklearn.base import clone
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skhybrid.exceptions import SimulationDivergedError, TrainingDivergedError
from skhybrid.experiments._greybox import TransformedInputs, fit_segments
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import simulate

__all__ = ["fit_zoo"]

#: Share of the estimation record held out at its end for every choice.
VALIDATION_FRACTION = 0.25


def _rmse(y, pred, n_init):
    return float(
        np.sqrt(np.mean((np.ravel(y)[n_init:] - np.ravel(pred)[n_init:]) ** 2))
    )


def _windows(columns, n):
    """Rows ``[c(t-n+1..t) for each column]`` for every t, edge-padded at the start."""
    X = np.column_stack(columns)
    padded = np.vstack([np.repeat(X[:1], n - 1, axis=0), X])
    view = np.lib.stride_tricks.sliding_window_view(padded, n, axis=0)
    return view.reshape(len(X), -1)


def _tail_split(u, y, fraction=VALIDATION_FRACTION):
    cut = int(len(u) * (1 - fraction))
    return (u[:cut], y[:cut]), (u[cut:], y[cut:])


def _records(u, y, n):
    """``n`` consecutive records of equal length (the rest joins the last)."""
    size = len(u) // n
    edges = [i * size for i in range(n)] + [len(u)]
    U, Y = zip(*[(u[a:b], y[a:b]) for a, b in itertools.pairwise(edges)], strict=True)
    return list(U), list(Y)


def _dense(quick, seed):
    from skhybrid.neural import DenseRegressor

    return DenseRegressor(
        hidden_layer_sizes=(64, 64),
        max_epochs=15 if quick else 60,
        patience=10,
        batch_size=256,
        lr=3e-3,
        random_state=seed,
    )


class _NARX:
    """A one-step NARX regressor (window of past outputs and inputs) run in free run."""

    def __init__(self, regressor, n_steps):
        self.regressor = regressor
        self.n_steps = n_steps

    def fit(self, u, y):
        layout = WindowLayout(n_states=1, n_inputs=1, n_steps=self.n_steps)
        X, target = layout.make_rows(y, u)
        self.model_ = make_pipeline(StandardScaler(), self.regressor).fit(X, target)
        return self

    def simulate(self, inputs, initial):
        return simulate(self.model_, inputs, initial)


class _PhysicsCorrection:
    """Physics simulated in free run plus a static map of its recent window.

    The correction reads ``[y_phys(t-n+1..t), u(t-n+1..t)]`` (the physics' own
    simulated output, never a measured one) and predicts ``y(t) - y_phys(t)``,
    so it adds no feedback loop and cannot destabilise the simulation.
    """

    def __init__(self, physics, regressor, n_steps):
        self.physics = physics
        self.regressor = regressor
        self.n_steps = n_steps

    def fit_on_physics(self, u, y, y_phys):
        X = _windows([y_phys, u], self.n_steps)
        self.model_ = make_pipeline(StandardScaler(), self.regressor).fit(
            X, np.ravel(y) - np.ravel(y_phys)
        )
        return self

    def correct(self, u, y_phys):
        X = _windows([y_phys, u], self.n_steps)
        return np.ravel(y_phys) + self.model_.predict(X).ravel()

    def simulate(self, inputs, initial):
        y_phys = self.physics.simulate(inputs, initial)
        return self.correct(inputs, y_phys)[:, None]


def _score(model, u, y, n_init):
    """Free-run RMSE of a record from its first ``n_init`` outputs (inf: failed)."""
    try:
        pred = model.simulate(u, y[:n_init])
    except (SimulationDivergedError, FloatingPointError, ValueError):
        return float("inf")
    value = _rmse(y, pred, n_init)
    return value if np.isfinite(value) else float("inf")


def _select_narx(make, u, y, n_init, candidates, notes, label):
    """The window length whose model simulates the validation tail best."""
    (u_a, y_a), (u_b, y_b) = _tail_split(u, y)
    scores = {}
    for n in candidates:
        try:
            model = make(n).fit(u_a, y_a)
        except (ValueError, FloatingPointError):
            scores[n] = float("inf")
            continue
        scores[n] = _score(model, u_b, y_b, max(n_init, n))
    best = min(scores, key=scores.get)
    notes[label] = {
        "validation_rmse": {str(k): v for k, v in scores.items()},
        "n": best,
    }
    return make(best).fit(u, y), scores[best]


def _fit_physics(system, u, y, dt, quick, segment, start=None):
    """The system's physics fitted on ``u``, ``y`` (from ``start``'s params)."""
    model = system.physics(u, y, dt, quick=quick)
    if start is not None:
        model.set_params(params=dict(start.params_))
    transform = system.physics_inputs
    u_model = u if transform is None else transform(u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit_segments(model, u_model, y, segment)
    return TransformedInputs(model, transform)


def _fit_state_space_hybrid(system, physics, u, y, n_init, settings, seed):
    """A :class:`StateSpaceHybridRegressor` on records cut from ``u``, ``y``."""
    from skhybrid.hybrid import StateSpaceHybridRegressor

    transform = system.physics_inputs
    u_model = u if transform is None else transform(u)
    U, Y = _records(u_model, y, system.hybrid_records)
    start = clone(physics.model).set_params(params=dict(physics.model.params_))
    model = StateSpaceHybridRegressor(
        start,
        n_init=n_init,
        warm_start_physics=False,
        random_state=seed,
        **settings,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit_simulation(U, Y)
    return TransformedInputs(model, transform)


def fit_zoo(system, train, n_init, dt, *, quick, seed, log):
    """Fit every model on the estimation record; return models, notes and choices.

    Parameters
    ----------
    system : MeasuredSystem
        The benchmark (physics, hybrid candidates, input transform).
    train : tuple of ndarray
        The estimation record ``(u, y)``.
    n_init : int
        Samples of the initialisation window (official).
    dt : float
        Sample period.
    quick : bool
        Shorter fits and fewer candidates.
    seed : int
        Seed of the networks.
    log : callable
        Receives progress lines.

    Returns
    -------
    models : dict
        Fitted models by label, each with ``simulate(inputs, initial)``.
    notes : dict
        Validation scores of every candidate and the choices made.
    fit_time : dict
        Seconds spent on each model (its candidates included).
    validation : dict
        Validation-tail RMSE of each model as quoted.
    """
    u, y = train
    (u_a, y_a), (u_b, y_b) = _tail_split(u, y)
    models, notes, fit_time, validation = {}, {}, {}, {}

    # Physics: fitted on the first 75 % with each candidate segment length
    # (multiple shooting; None is one free run per record), scored on the tail;
    # the best is refitted on the whole record from there.
    start = time.perf_counter()
    fits, scores = {}, {}
    for segment in system.segments:
        fits[segment] = _fit_physics(system, u_a, y_a, dt, quick, segment)
        scores[segment] = _score(fits[segment], u_b, y_b, n_init)
    segment = min(scores, key=scores.get)
    physics_a = fits[segment]
    validation["physics"] = scores[segment]
    physics = _fit_physics(system, u, y, dt, quick, segment, start=physics_a)
    models["physics"] = physics
    fit_time["physics"] = time.perf_counter() - start
    notes["physics"] = {
        "validation_rmse_by_segment": {str(k): v for k, v in scores.items()},
        "segment": segment,
        "validation_rmse": validation["physics"],
        "estimation_rmse": physics.rmse_,
    }
    log(
        f"  physics fitted in {fit_time['physics']:.1f} s "
        f"(validation {validation['physics']:.4g})"
    )

    lags = (2, 4, 8) if not quick else (2, 4)
    start = time.perf_counter()
    models["linear ARX"], validation["linear ARX"] = _select_narx(
        lambda n: _NARX(Ridge(alpha=1e-6), n), u, y, n_init, lags, notes, "linear ARX"
    )
    fit_time["linear ARX"] = time.perf_counter() - start

    start = time.perf_counter()
    n_lin = notes["linear ARX"]["n"]
    dense_a = _NARX(_dense(quick, seed), n_lin).fit(u_a, y_a)
    validation["dense NARX"] = _score(dense_a, u_b, y_b, max(n_init, n_lin))
    models["dense NARX"] = _NARX(_dense(quick, seed), n_lin).fit(u, y)
    notes["dense NARX"] = {
        "n": n_lin,
        "chosen": "the linear ARX's window",
        "validation_rmse": validation["dense NARX"],
    }
    fit_time["dense NARX"] = time.perf_counter() - start
    log(f"  dense NARX fitted in {fit_time['dense NARX']:.1f} s")

    # Static corrections of the physics' free run (physics_a's on the tail).
    y_phys_a = np.ravel(physics_a.simulate(u_a, y_a[:n_init]))
    y_phys_b = np.ravel(physics_a.simulate(u_b, y_b[:n_init]))
    y_phys = np.ravel(physics.simulate(u, y[:n_init]))
    for label, make in (
        ("physics + linear", lambda: Ridge(alpha=1e-3)),
        ("physics + dense", lambda: _dense(quick, seed)),
    ):
        start = time.perf_counter()
        scores = {}
        for n in (1, 10, 50) if not quick else (1, 10):
            corr = _PhysicsCorrection(physics_a, make(), n)
            corr.fit_on_physics(u_a, y_a, y_phys_a)
            scores[n] = _rmse(y_b, corr.correct(u_b, y_phys_b), n_init)
        best = min(scores, key=scores.get)
        notes[label] = {
            "validation_rmse": {str(k): v for k, v in scores.items()},
            "n": best,
        }
        validation[label] = scores[best]
        models[label] = _PhysicsCorrection(physics, make(), best).fit_on_physics(
            u, y, y_phys
        )
        fit_time[label] = time.perf_counter() - start
        log(f"  {label} fitted in {fit_time[label]:.1f} s")

    # The state-space hybrid, trained by the simulation error over T steps; T and
    # the architecture chosen on the tail. The chosen one is quoted as fitted on
    # the first 75 % (a refit on the whole record would double the time).
    candidates = system.hybrid_candidates(quick)
    if candidates:
        label = "state-space hybrid"
        start = time.perf_counter()
        scores, fitted = {}, {}
        for name, settings in candidates.items():
            t0 = time.perf_counter()
            try:
                model = _fit_state_space_hybrid(
                    system, physics_a, u_a, y_a, n_init, settings, seed
                )
            except (TrainingDivergedError, SimulationDivergedError) as exc:
                scores[name] = float("inf")
                log(f"  {label} {name}: {exc}")
                continue
            scores[name] = _score(model, u_b, y_b, n_init)
            fitted[name] = model
            log(
                f"  {label} {name}: validation {scores[name]:.4g} "
                f"({time.perf_counter() - t0:.0f} s, {model.n_epochs_} epochs)"
            )
        best = min(scores, key=scores.get)
        notes[label] = {
            "validation_rmse": scores,
            "chosen": best,
            "settings": {k: repr(v) for k, v in candidates[best].items()},
            "fitted_on": "the first 75 % of the estimation record",
        }
        if best in fitted:
            models[label] = fitted[best]
            validation[label] = scores[best]
        fit_time[label] = time.perf_counter() - start
    return models, notes, fit_time, validation
