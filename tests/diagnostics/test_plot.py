"""Tests of the Displays: they render under Agg and hold the expected artists."""

import numpy as np
import pytest
from matplotlib.collections import LineCollection, PolyCollection
from numpy.testing import assert_allclose
from scipy.signal import lfilter
from sklearn.linear_model import LinearRegression
from sklearn.utils import Bunch

from skhybrid.diagnostics import (
    DecompositionDisplay,
    ResidualACFDisplay,
    RMSEBoxDisplay,
    ljung_box_test,
    rmse_db,
)


def _series(rng, n=600):
    white = rng.standard_normal(n)
    ar = lfilter([1.0], [1.0, -0.6], rng.standard_normal(n))
    return np.column_stack([white, ar])


# ----------------------------------------------------------------------------------
# ResidualACFDisplay
# ----------------------------------------------------------------------------------
def test_residual_acf_display_from_predictions(pyplot, rng):
    y = _series(rng)
    disp = ResidualACFDisplay.from_predictions(
        y, np.zeros_like(y), lags=12, output_names=["theta", "omega"], name="physics"
    )
    assert disp.axes_.shape == (2,)
    assert len(disp.figure_.axes) == 2
    assert disp.ax_ is disp.axes_[0]
    pvalues = ljung_box_test(y, lags=12).pvalue
    for j, (ax, name) in enumerate(zip(disp.axes_, ["theta", "omega"], strict=True)):
        title = ax.get_title()
        assert "physics" in title and name in title
        expected = "p < 0.0001" if pvalues[j] < 1e-4 else f"p = {pvalues[j]:.3g}"
        assert expected in title
        assert isinstance(disp.bands_[j], PolyCollection)
        assert disp.bands_[j] in ax.collections
        assert isinstance(disp.stems_[j], LineCollection)
        assert len(disp.stems_[j].get_segments()) == 12  # lags 1..12: zero lag gone
        assert 0 not in disp.markers_[j].get_xdata()
    # The white-noise band: z / sqrt(n) at every lag.
    band = disp.bands_[0].get_paths()[0].vertices[:, 1]
    assert_allclose(np.abs(band).max(), 1.959964 / np.sqrt(600), rtol=1e-4)


def test_residual_acf_display_from_estimator_and_given_axes(pyplot, rng):
    X = rng.standard_normal((400, 2))
    y = X @ [1.0, -2.0] + 0.1 * rng.standard_normal(400)
    est = LinearRegression().fit(X, y)
    fig, ax = pyplot.subplots()
    disp = ResidualACFDisplay.from_estimator(est, X, y, lags=8, ax=ax)
    assert disp.ax_ is ax and disp.figure_ is fig
    assert disp.ax_.get_title().startswith("LinearRegression\ny: Ljung-Box(8) p = ")


def test_residual_acf_display_rejects_wrong_axes(pyplot, rng):
    y = _series(rng, 100)
    _, ax = pyplot.subplots()
    with pytest.raises(ValueError, match=r"ax must hold one Axes per panel"):
        ResidualACFDisplay.from_predictions(y, np.zeros_like(y), lags=5, ax=ax)


def test_residual_acf_display_plot_from_constructor(pyplot):
    disp = ResidualACFDisplay(
        lags=np.arange(4),
        acf=np.array([1.0, 0.5, 0.2, 0.0]),
        band=np.full(4, 0.1),
        pvalue=[0.001],
    ).plot()
    assert len(disp.stems_[0].get_segments()) == 3  # lag 0 suppressed
    assert disp.ax_.get_title() == "y: Ljung-Box p = 0.001"
    disp = ResidualACFDisplay(
        lags=np.arange(1, 3), acf=np.ones(2), band=np.ones(2), pvalue=[1e-30]
    ).plot()
    assert disp.ax_.get_title() == "y: Ljung-Box p < 0.0001"


# ----------------------------------------------------------------------------------
# RMSEBoxDisplay
# ----------------------------------------------------------------------------------
def _predictions(rng, y):
    return {
        name: y + scale * rng.standard_normal(y.shape)
        for name, scale in [("physics", 0.3), ("physics+RNN", 0.05), ("RNN", 0.1)]
    }


def test_rmse_box_display_from_predictions(pyplot, rng):
    y = rng.standard_normal((1000, 2))
    preds = _predictions(rng, y)
    disp = RMSEBoxDisplay.from_predictions(y, preds, window=50)
    assert disp.axes_.shape == (2,)
    assert len(disp.boxes_) == 2
    for j, (ax, artists) in enumerate(zip(disp.axes_, disp.boxes_, strict=True)):
        assert len(artists["boxes"]) == 3
        assert [t.get_text() for t in ax.get_xticklabels()] == list(preds)
        for k, pred in enumerate(preds.values()):
            scores = rmse_db(y, pred, window=50)[:, j]
            assert_allclose(artists["medians"][k].get_ydata()[0], np.median(scores))
            # Whiskers at the 5th and 95th percentiles.
            low = artists["whiskers"][2 * k].get_ydata()[1]
            high = artists["whiskers"][2 * k + 1].get_ydata()[1]
            assert_allclose([low, high], np.percentile(scores, [5, 95]))
            mean = artists["means"][k]
            assert mean.get_marker() == "^"
            assert_allclose(mean.get_ydata()[0], scores.mean())
    assert "50-sample windows" in disp.ax_.get_ylabel()


def test_rmse_box_display_from_estimator_and_scores(pyplot, rng):
    X = rng.standard_normal((600, 3))
    y = X @ [1.0, 0.5, -1.0] + 0.2 * rng.standard_normal(600)
    models = {
        "full": LinearRegression().fit(X, y),
        "two inputs": LinearRegression().fit(X[:, :2], y),
    }

    class _FirstTwo:
        def __init__(self, est):
            self.est = est

        def predict(self, X):
            return self.est.predict(X[:, :2])

    models["two inputs"] = _FirstTwo(models["two inputs"])
    disp = RMSEBoxDisplay.from_estimator(models, X, y, window=40)
    assert disp.axes_.shape == (1,)
    medians = [line.get_ydata()[0] for line in disp.boxes_[0]["medians"]]
    assert medians[0] < medians[1]  # the full model has the smaller error
    scores = {"a": np.array([[-20.0], [-19.0], [-21.0]]), "b": [-10.0, -12.0, -11.0]}
    disp = RMSEBoxDisplay.from_rmse_db(scores, output_names=["theta"])
    assert len(disp.boxes_[0]["boxes"]) == 2 and disp.ax_.get_title() == "theta"


def test_rmse_box_display_rejects_bad_input(pyplot):
    with pytest.raises(TypeError, match="y_pred must be a non-empty dict"):
        RMSEBoxDisplay.from_predictions(np.zeros(10), np.zeros(10), window=5)
    with pytest.raises(ValueError, match="non-finite"):
        RMSEBoxDisplay.from_predictions(np.zeros(10), {"exact": np.zeros(10)}, window=5)
    with pytest.raises(ValueError, match=r"y_pred\['a'\] must have the shape"):
        RMSEBoxDisplay.from_predictions(np.zeros(10), {"a": np.zeros(9)}, window=5)


# ----------------------------------------------------------------------------------
# DecompositionDisplay
# ----------------------------------------------------------------------------------
def _pendulum_like(n=400):
    t = np.linspace(0.0, 20.0, n)
    physics = np.column_stack([np.cos(t), -np.sin(t)])
    neural = 0.15 * np.column_stack([np.sin(3 * t), np.cos(3 * t)])
    noise = 0.03 * np.random.default_rng(0).standard_normal((n, 2))
    return t, physics, neural, physics + neural + noise


class _FakeHybrid:
    """What the hybrid module's decompose promises, without importing it."""

    def __init__(self, physics, neural, std=None):
        self.physics, self.neural, self.std = physics, neural, std

    def decompose(self, X):
        total = self.physics + self.neural
        return Bunch(
            stage_names=["physics", "rnn"],
            physics=self.physics,
            rnn=self.neural,
            total=total,
        )

    def predict(self, X, return_std=False):
        total = self.physics + self.neural
        if return_std:
            return total, self.std
        return total


def test_decomposition_display_from_decomposition(pyplot):
    t, physics, neural, y = _pendulum_like()
    disp = DecompositionDisplay.from_decomposition(
        {"physics": physics, "rnn": neural}, y, time=t, output_names=["cos", "sin"]
    )
    assert disp.axes_.shape == (2, 2)
    assert len(disp.figure_.axes) == 4
    assert len(disp.bands_) == 2
    assert all(isinstance(b, PolyCollection) for b in disp.bands_)
    for key in ("measured", "total", "physics", "rnn"):
        assert len(disp.lines_[key]) == 2
    assert_allclose(disp.lines_["physics"][1].get_ydata(), physics[:, 1])
    assert_allclose(disp.lines_["rnn"][0].get_ydata(), neural[:, 0])
    # Band from the residual std: half-width 2 * std(y - total), around the rnn part.
    half = 2 * np.std(y - physics - neural, axis=0)
    assert_allclose(disp.upper - disp.lower, 2 * half[None, :] * np.ones_like(y))
    edges = disp.bands_[0].get_paths()[0].vertices[:, 1]
    assert_allclose(edges.max(), (neural[:, 0] + half[0]).max(), rtol=1e-9)
    assert "residual" in disp.band_label
    assert disp.axes_[0, 0].get_title() == "cos"


def test_decomposition_display_from_estimator_uses_noise_std(pyplot):
    t, physics, neural, y = _pendulum_like()
    std = np.full(len(t), 0.05)
    disp = DecompositionDisplay.from_estimator(
        _FakeHybrid(physics, neural, std), np.zeros((len(t), 1)), y
    )
    assert_allclose(disp.upper - disp.lower, 0.2)
    assert "noise model" in disp.band_label
    assert disp.figure_._suptitle.get_text() == "_FakeHybrid"


def test_decomposition_display_estimator_without_std_or_decompose(pyplot):
    _, physics, neural, y = _pendulum_like(100)

    class _NoStd(_FakeHybrid):
        def predict(self, X):
            return self.physics + self.neural

    disp = DecompositionDisplay.from_estimator(
        _NoStd(physics, neural), np.zeros((100, 1)), y, name="hybrid"
    )
    assert "residual" in disp.band_label
    with pytest.raises(TypeError, match="decompose"):
        DecompositionDisplay.from_estimator(LinearRegression(), np.zeros((100, 1)), y)


def test_decomposition_display_rejects_bad_shapes(pyplot):
    t, physics, neural, y = _pendulum_like(50)
    with pytest.raises(ValueError, match=r"parts\['rnn'\] must have the shape"):
        DecompositionDisplay.from_decomposition(
            {"physics": physics, "rnn": neural[:, 0]}, y
        )
    with pytest.raises(ValueError, match="time must have shape"):
        DecompositionDisplay.from_decomposition({"physics": physics}, y, time=t[:10])
    with pytest.raises(ValueError, match="std must have shape"):
        DecompositionDisplay.from_decomposition(
            {"physics": physics}, y, std=np.ones((50, 3))
        )
