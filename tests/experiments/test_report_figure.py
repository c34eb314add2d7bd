"""The measured report's figure and failure reasons."""

import numpy as np

from skhybrid.experiments.free_run._report import _limits, failure_reason


def test_the_axis_is_the_measured_signals_with_a_margin():
    low, high = _limits(np.array([0.0, 1.0, np.nan, 2.0]))
    assert (low, high) == (-0.5, 2.5)
    # A flat signal still gets an axis around it.
    low, high = _limits(np.full(5, 3.0))
    assert low < 3.0 < high


class _Result:
    def __init__(self, fits):
        self.fits = fits


class _Run:
    def __init__(self, fits):
        self.results = [_Result(fits)]


def test_a_failed_figure_says_why():
    run = _Run(
        {
            "a": {"selection": {"failed": "every candidate's fit failed"}},
            "b": {"selection": {"diverged_on_test": "state left its bounds"}},
            "c": {"selection": {}},
        }
    )
    assert "every candidate" in failure_reason(run, "test", "a")
    assert "diverged: state left its bounds" in failure_reason(run, "test", "b")
    assert "not defined" in failure_reason(run, "test_original_protocol", "c")
    assert failure_reason(run, "test", "c") is None
