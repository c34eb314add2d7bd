"""StateSpaceModel(starts=...), random_starts: the fit goes on from the best start."""

import warnings

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils._param_validation import InvalidParameterError

from skhybrid.domain import StateSpaceModel, random_starts


def ring(x, u, *, xp, w, r):
    """A free oscillation: the state turns by ``w`` a step and shrinks by ``r``."""
    c, s = x[:, 0], x[:, 1]
    return xp.stack(
        [r * (xp.cos(w) * c - xp.sin(w) * s), r * (xp.sin(w) * c + xp.cos(w) * s)],
        axis=1,
    )


def _model(params, **kwargs):
    kwargs.setdefault("fixed", ("r",))
    kwargs.setdefault("bounds", {"w": (0.01, 3.0)})
    return StateSpaceModel(
        ring,
        params,
        state_names=["cos", "sin"],
        observed=["cos"],
        time="discrete",
        n_init=10,
        vectorized=True,
        **kwargs,
    )


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(0)
    u = np.zeros((300, 0))
    truth = _model({"w": 0.3, "r": 0.998}, fixed=("w", "r"))
    truth.fit_simulation(u, np.zeros((300, 1)))
    y = truth.simulate_from_state(u, [1.0, 0.0])
    return u, y + 0.01 * rng.standard_normal(y.shape)


def _fit(model, u, y):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.fit_simulation(u, y)


START = {"w": 0.36, "r": 0.998}  # 1.2x the truth's frequency
STARTS = [{"w": 0.15}, {"w": 0.31}, {"w": 1.0}]


def test_a_start_a_fifth_off_stops_where_starts_find_the_truth(record):
    u, y = record
    direct = _fit(_model(START), u, y)
    # The simulation error of a free oscillation is many-valleyed in its
    # frequency: from 1.2x the truth the fit stops in the next valley.
    assert abs(direct.params_["w"] - 0.3) > 0.05 and direct.rmse_ > 0.5
    with warnings.catch_warnings():
        # The short fits stop short of convergence; only the final fit warns.
        warnings.simplefilter("error", ConvergenceWarning)
        fitted = _model(START, starts=STARTS).fit_simulation(u, y)
    assert fitted.params_["w"] == pytest.approx(0.3, abs=1e-3)
    assert fitted.rmse_ < 0.012
    # The model's own parameters are unchanged: the starts only move the fit.
    assert fitted.params == START


def test_the_fit_goes_on_from_the_best_short_fit(record):
    u, y = record
    model = _model(START, starts=STARTS, starts_nfev=3)
    fitted = _fit(model, u, y)
    shorts = [_fit(_model({**START, **s}, max_nfev=3), u, y) for s in [{}, *STARTS]]
    best = min(shorts, key=lambda m: m.result_.cost)
    by_hand = _fit(_model({**START, **best.params_}), u, y)
    assert fitted.params_["w"] == pytest.approx(by_hand.params_["w"], rel=1e-12)
    # The one-step fit runs the same starts.
    X = np.column_stack([y[:-1], y[1:]])[:-1]
    one_step = _model(START, starts=STARTS, n_steps=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one_step.fit(X, y[2:, 0])
    assert np.isfinite(one_step.params_["w"])


def test_starts_fitted_to_convergence_keep_the_lowest_cost(record):
    u, y = record
    fitted = _fit(_model(START, starts=STARTS, starts_nfev=None), u, y)
    full = [_fit(_model({**START, **s}), u, y) for s in [{}, *STARTS]]
    best = min(full, key=lambda m: m.result_.cost)
    assert fitted.result_.cost <= best.result_.cost * (1 + 1e-9)
    assert fitted.params_["w"] == pytest.approx(best.params_["w"], rel=1e-6)


def test_a_start_whose_short_fit_fails_is_dropped(record):
    u, y = record
    # r is free here and a start at 1e3 overflows the free run.
    fitted = _fit(
        _model(START, fixed=(), bounds=None, starts=[{"r": 1e3}, {"w": 0.31}]), u, y
    )
    assert fitted.params_["w"] == pytest.approx(0.3, abs=1e-3)


def test_starts_compose_with_a_continuation(record):
    u, y = record
    fitted = _fit(
        _model(START, fixed=("r",), starts=STARTS, continuation={"r": [0.99]}), u, y
    )
    assert fitted.params_["w"] == pytest.approx(0.3, abs=1e-3)


@pytest.mark.parametrize(
    "starts, error, match",
    [
        ({"w": 0.3}, InvalidParameterError, "The 'starts' parameter"),
        ([], TypeError, "starts must be a non-empty list"),
        ([0.3], TypeError, "every entry of starts must be a dict"),
        ([{"r": 0.9}], ValueError, "starts names 'r', which is not a free"),
        ([{"q": 0.9}], ValueError, "starts names 'q'"),
        ([{"w": float("nan")}], ValueError, r"starts\[0\]\['w'\] must be a finite"),
        ([{"w": "fast"}], ValueError, r"got 'fast'"),
        # Outside the bounds (0.01, 3.0): refused as params outside them are,
        # where the short fit used to fail and drop the start in silence.
        (
            [{"w": 0.31}, {"w": 5.0}],
            ValueError,
            r"starts\[1\]\['w'\] is 5.0, outside its bounds \(0.01, 3.0\)",
        ),
    ],
)
def test_bad_starts_are_named(record, starts, error, match):
    u, y = record
    with pytest.raises(error, match=match):
        _model(START, starts=starts).fit_simulation(u, y)


def test_bad_starts_nfev_is_named(record):
    u, y = record
    with pytest.raises(InvalidParameterError, match="starts_nfev"):
        _model(START, starts=STARTS, starts_nfev=0).fit_simulation(u, y)


def test_random_starts_lie_within_the_factor_and_the_bounds():
    model = StateSpaceModel(
        ring,
        {"w": 0.5, "r": 0.998, "z": 0.0},
        state_names=["cos", "sin"],
        fixed=("r",),
        bounds={"w": (0.3, 3.0)},
        time="discrete",
    )
    starts = random_starts(model, 200, factor=2.0, random_state=0)
    assert len(starts) == 200 and all(sorted(s) == ["w", "z"] for s in starts)
    w = np.array([s["w"] for s in starts])
    assert w.min() >= 0.3 and w.max() <= 1.0 and w.min() == 0.3  # clipped
    assert np.ptp(np.log(w[w > 0.3])) > 0.5  # spread, not one value
    assert all(s["z"] == 0.0 for s in starts)
    assert starts == random_starts(model, 200, factor=2.0, random_state=0)
    assert starts != random_starts(model, 200, factor=2.0, random_state=1)
    with pytest.raises(
        ValueError, match="n_starts must be an int >= 1; got n_starts=0"
    ):
        random_starts(model, 0)
    with pytest.raises(ValueError, match="factor must be a finite number > 1"):
        random_starts(model, 3, factor=1.0)


def test_random_starts_names_a_model_that_is_not_one():
    # random_starts("x", 3) was an AttributeError.
    with pytest.raises(TypeError, match=r"model must be .* got model='x' of type str"):
        random_starts("x", 3)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), [0.1, 0.2]])
def test_random_starts_refuses_params_that_are_not_finite_scalars(value):
    # NaN in params gave NaN starts.
    model = StateSpaceModel(
        ring, {"w": value, "r": 0.998}, state_names=["cos", "sin"], time="discrete"
    )
    with pytest.raises(ValueError, match=r"finite scalars; got params\['w'\]="):
        random_starts(model, 3)


def test_the_chosen_start_is_handed_to_the_final_fit_as_a_value(record, monkeypatch):
    # It was a hidden attribute (_chosen_start) read back via self.__dict__.
    u, y = record
    calls = []
    original = StateSpaceModel._fit_simulation

    def spy(self, inputs, outputs, start=None):
        calls.append((start, sorted(vars(self))))
        return original(self, inputs, outputs, start=start)

    monkeypatch.setattr(StateSpaceModel, "_fit_simulation", spy)
    fitted = _fit(_model(START, starts=STARTS), u, y)
    # The short fits (clones, one per start) start from their own params.
    assert [start for start, _ in calls[:-1]] == [None] * (len(STARTS) + 1)
    start, attributes = calls[-1]
    assert start["r"] == START["r"] and abs(start["w"] - 0.3) < 0.05
    assert not [a for a in attributes if "start" in a and not a.startswith("starts")]
    assert fitted.params_["w"] == pytest.approx(0.3, abs=1e-3)


def test_the_short_fits_run_in_lockstep_as_one_batch(record, monkeypatch):
    # The starts' short fits run side by side and their free runs are
    # simulated together: fewer simulations than one after another, and the
    # same fit as with the starts' batches apart.
    from skhybrid.domain import _starts

    u, y = record
    calls = {"n": 0, "rows": []}
    simulate = StateSpaceModel._simulate_records

    def counted(self, U, *args, **kwargs):
        calls["n"] += 1
        calls["rows"].append(len(U))
        return simulate(self, U, *args, **kwargs)

    monkeypatch.setattr(StateSpaceModel, "_simulate_records", counted)
    model = _model(START, starts=STARTS, starts_nfev=5)
    together = _fit(model, u, y)
    n_together, rows = calls["n"], calls["rows"]

    def one_by_one(models, fit):
        return [fit(m) for m in models]

    calls.update(n=0, rows=[])
    monkeypatch.setattr(_starts, "run_in_lockstep", one_by_one)
    apart = _fit(_model(START, starts=STARTS, starts_nfev=5), u, y)
    # Four short fits batched: some simulations carry several fits' sets.
    assert n_together < calls["n"]
    assert max(rows) > max(calls["rows"])
    assert together.params_["w"] == pytest.approx(apart.params_["w"], rel=1e-9)


def test_rows_of_several_fits_run_as_one_and_each_reads_its_own(record, monkeypatch):
    # Requests of other records (other lengths) and parameter sets are merged
    # into one run, padded; each gets the residuals it gets alone. Past the
    # size limit they are run in chunks, with the same results.
    from skhybrid.domain import _state_space_batch as batch

    u, y = record
    models = []
    for n, w in ((300, 0.3), (220, 0.25)):
        model = _model({"w": w, "r": 0.998})
        _fit(model.set_params(max_nfev=1), u[:n], y[:n])
        models.append(model)
    requests = []
    for model, n in zip(models, (300, 220), strict=True):
        # The records a fit holds while it runs (fit_simulation's own).
        mask = np.ones((1, n), bool)
        model._records = (u[None, :n], y[None, :n], mask, model._structure())
        thetas = np.array([[0.3], [0.31], [0.29]])
        requests.append(model._set_rows(thetas, model._spec))
    alone = [r.simulate() for r in requests]
    for limit in (2**21, 500):
        monkeypatch.setattr(batch, "MAX_RUN_SAMPLES", limit)
        together = batch.simulate_rows(requests)
        for a, b in zip(alone, together, strict=True):
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-14)
    assert len(batch._chunks([0, 1], requests)) == 2  # 500 splits them
