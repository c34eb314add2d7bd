"""The report reads its own numbers: verdicts on white and coloured residuals."""

import numpy as np
import pytest
from scipy.signal import lfilter
from sklearn.utils import Bunch

from skhybrid.experiments._stochastic import residual_tests
from skhybrid.experiments.free_run._report import (
    _chosen_cv_text,
    _params_html,
    _stochastic_html,
    legend_beside,
)
from skhybrid.experiments.free_run._verdicts import (
    coverage_verdict,
    input_verdict,
    standard_error_caveat,
    whiteness_verdict,
)

N = 2000


@pytest.fixture
def inputs():
    rng = np.random.default_rng(0)
    return rng.standard_normal((N, 1))


def white(seed=1):
    return np.random.default_rng(seed).standard_normal(N)


def coloured(u):
    """What a physics missing a term leaves: filtered input and AR(1) noise."""
    noise = lfilter([1.0], [1.0, -0.8], white(2))
    return lfilter([0.0, 0.5, 0.3], [1.0, -0.6], u[:, 0]) + 0.2 * noise


def test_white_residuals_read_white_and_independent_of_the_inputs(inputs):
    tests = residual_tests(white(), inputs)
    assert whiteness_verdict(tests["ljung_box_pvalue"]) == "white at 5 %"
    assert input_verdict(tests["input_correlation_pvalue"]) == (
        "no input dependence left at 5 %"
    )


def test_coloured_residuals_read_not_white_and_explained_by_the_inputs(inputs):
    tests = residual_tests(coloured(inputs), inputs)
    assert whiteness_verdict(tests["ljung_box_pvalue"]) == (
        "not white at 5 %: the residuals are correlated in time"
    )
    assert input_verdict(tests["input_correlation_pvalue"]).startswith(
        "inputs still explain the residuals at 5 %"
    )


def test_untested_figures_say_so():
    assert whiteness_verdict(None).startswith("not tested")
    assert input_verdict(None) == "input dependence not tested"
    assert coverage_verdict(None, 0.95) == "no coverage (the free run failed)"


@pytest.mark.parametrize(
    ("coverage", "reading"),
    [
        (0.908, "the band covers 91 % of the samples against its 95 %: too narrow"),
        (0.94, "the band covers 94 % of the samples against its 95 %: about right"),
        (0.995, "the band covers 100 % of the samples against its 95 %: too wide"),
    ],
)
def test_a_band_reads_too_narrow_about_right_or_too_wide(coverage, reading):
    assert coverage_verdict(coverage, 0.95) == reading


def test_standard_errors_are_conditional_and_flagged_on_coloured_residuals(inputs):
    flagged = standard_error_caveat(
        residual_tests(coloured(inputs), inputs)["ljung_box_pvalue"]
    )
    assert "conditional on the physics' structure" in flagged
    assert "Warning: its residuals are not white at 5 %" in flagged
    assert "understate the uncertainty" in flagged
    plain = standard_error_caveat(residual_tests(white(), inputs)["ljung_box_pvalue"])
    assert "conditional on the physics' structure" in plain
    assert "Warning" not in plain and plain.endswith("white at 5 %")


def _summary(validation, test, physics):
    noise = {
        "fitted": True,
        "lags": [1],
        "std": 0.1,
        "innovation_std": 0.05,
        "mean": 0.0,
    }
    part = {
        "model": "physics + dense",
        "level": 0.95,
        "noise": noise,
        "validation": validation,
        "physics_validation": physics,
        "tests": {"test": test},
    }
    return {
        "stochastic": {"0": part},
        "band_coverage": {"test": {"mean": test["coverage"], "std": 0.0}},
        "chosen_model": {"0": "physics + dense"},
        "cv_rmse": {"0": {"physics + dense": {"mean": 0.0123, "std": 0.002}}},
    }


def _run(value, std):
    params = {"physics": {"k": {"value": value, "std": std}}}
    return Bunch(results=[Bunch(settings=Bunch(seed=0), params=params)])


def test_the_report_writes_each_tests_verdict_beside_it(inputs):
    # A spec whose physics misses a term: coloured residuals everywhere.
    bad = residual_tests(coloured(inputs), inputs)
    summary = _summary(bad, {**bad, "coverage": 0.908}, bad)
    page = _stochastic_html(summary, "m")
    assert "not white at 5 %: the residuals are correlated in time" in page
    assert "inputs still explain the residuals at 5 %" in page
    assert "the band covers 91 % of the samples against its 95 %: too narrow" in page
    params = _params_html(_run(31.38, 0.38), summary)
    assert "k = 31.38 &plusmn; 0.38" in params
    assert "Warning: its residuals are not white at 5 %" in params
    # The chosen model's row shows its CV figure.
    assert _chosen_cv_text(summary) == "0.0123 &plusmn; 0.002"
    # A spec whose model is right: white residuals, no warning.
    good = residual_tests(white(), inputs)
    summary = _summary(good, {**good, "coverage": 0.95}, good)
    page = _stochastic_html(summary, "m")
    assert "white at 5 %; no input dependence left at 5 %" in page
    assert "about right" in page and "not white" not in page
    params = _params_html(_run(20.0, 0.1), summary)
    assert "conditional on the physics&#x27; structure" in params
    # Several seeds with one reading: the caveat said once.
    run = _run(20.0, 0.1)
    run.results.append(Bunch(settings=Bunch(seed=1), params=run.results[0].params))
    summary["stochastic"]["1"] = summary["stochastic"]["0"]
    twice = _params_html(run, summary)
    assert twice.count("seed ") == 2 and twice.count("conditional on") == 1
    assert "Warning" not in params


def test_a_legend_beside_its_panel_covers_no_data():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.5, 6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    t = np.linspace(0, 10, 200)
    for k in range(8):
        ax.plot(t, np.sin(t + k), label=f"a model with a long name {k}")
    legend = legend_beside(ax)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box, panel = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
    assert box.x0 >= panel.x1  # beside the panel, not over it
    assert box.x1 <= fig.bbox.x1 + 1  # and inside the figure
