"""The booster as a composite: HTML representation, stages by name and index, and
the n_steps message that names the right parameter (issue 26)."""

from html.parser import HTMLParser

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError
from sklearn.linear_model import Ridge
from sklearn.utils import Bunch, estimator_html_repr

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.preprocessing import make_windows


def _windows(n_steps, n=200, seed=0, shuffle=False):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, size=(n, 1))
    x = np.zeros((n, 1))
    for t in range(n - 1):
        x[t + 1] = 0.7 * x[t] + 0.5 * u[t] + 0.05 * rng.standard_normal()
    X, y = make_windows(x, u, n_steps=n_steps)
    if shuffle:
        perm = rng.permutation(len(X))
        X, y = X[perm], y[perm]
    return X, y[:, 0]


class _Labels(HTMLParser):
    """The text of every box label (``sk-toggleable__label``) of an HTML repr."""

    def __init__(self):
        super().__init__()
        self.labels, self._depth = [], 0

    def handle_starttag(self, tag, attrs):
        if self._depth:
            self._depth += 1
        elif tag == "label" and "sk-toggleable__label" in dict(attrs).get("class", ""):
            self._depth = 1
            self.labels.append("")

    def handle_endtag(self, tag):
        if self._depth:
            self._depth -= 1

    def handle_data(self, data):
        if self._depth:
            self.labels[-1] += data


def _labels(estimator):
    parser = _Labels()
    parser.feed(estimator_html_repr(estimator))
    return [" ".join(text.split()) for text in parser.labels]


def _booster(**kwargs):
    return HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel()), ("ridge", Ridge(alpha=1e-3))],
        **kwargs,
    )


@pytest.mark.parametrize("fitted", [False, True])
def test_html_repr_shows_each_stage(fitted):
    """One labelled box per stage, in order, as a Pipeline shows its steps."""
    booster = _booster()
    if fitted:
        booster.fit(*_windows(1))
    labels = _labels(booster)
    starts = [
        next(i for i, t in enumerate(labels) if t.startswith(word))
        for word in (
            "HybridBoostingRegressor",
            "physics",
            "LinearStateSpaceModel",
            "ridge",
            "Ridge",
        )
    ]
    assert starts == sorted(starts), labels
    assert "sk-serial" in estimator_html_repr(booster)
    # The stage boxes list their parameters under the names set_params takes.
    assert "physics__" in estimator_html_repr(booster)


def test_html_repr_marks_dropped_stages():
    X, y = _windows(1)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel()), ("useless", Ridge(alpha=1e9))],
        drop_unhelpful_stages=True,
    ).fit(X, y)
    assert booster.dropped_stages_ == ["useless"]
    assert any(t.startswith("useless: dropped") for t in _labels(booster))
    with pytest.raises(KeyError, match="dropped by drop_unhelpful_stages"):
        booster["useless"]


def test_fitted_stages_by_name_and_index():
    X, y = _windows(1)
    booster = _booster().fit(X, y)
    named = booster.named_stages_
    assert isinstance(named, Bunch) and list(named) == ["physics", "ridge"]
    physics, ridge = booster.stages_[0][1], booster.stages_[1][1]
    assert named.physics is physics and named["ridge"] is ridge
    assert booster[0] is physics and booster[-1] is ridge
    assert booster["ridge"] is ridge and booster[np.int64(1)] is ridge
    # A fitted stage is the estimator itself: it predicts and simulates.
    assert booster[0].predict(X[:3]).shape[0] == 3
    assert hasattr(booster[0], "simulate")
    # The unfitted templates stay apart from the fitted clones.
    assert booster.named_stages.physics is not physics
    with pytest.raises(IndexError, match=r"out of range.*2 fitted stages"):
        booster[2]
    with pytest.raises(KeyError, match="no fitted stage named 'nn'"):
        booster["nn"]
    with pytest.raises(TypeError, match="position \\(int\\) or name \\(str\\)"):
        booster[0.5]


def test_stages_need_a_fit():
    booster = _booster()
    with pytest.raises(NotFittedError):
        booster.named_stages_  # noqa: B018
    with pytest.raises(NotFittedError):
        booster[0]
    assert not hasattr(booster, "named_stages_")


def test_n_steps_message_names_the_booster_when_the_rows_say_so():
    """Issue 26: a booster left at n_steps=1 under a stage with n_steps=2.

    The rows are windows of 2 steps; the fix is the booster's n_steps, not the
    stage's (the old message led with "set physics__n_steps=1").
    """
    X, y = _windows(2)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel(n_steps=2)), ("ridge", Ridge())]
    )
    with pytest.raises(ValueError) as info:
        booster.fit(X, y)
    message = str(info.value)
    assert "continue each other as windows of 2 steps" in message
    assert "set n_steps=2 on the booster" in message
    assert "physics__n_steps=1" not in message
    booster.set_params(n_steps=2).fit(X, y)  # the fix the message names works


def test_n_steps_message_names_the_stage_when_the_rows_say_so():
    X, y = _windows(3)
    booster = HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel(n_steps=3)),
            ("lin", LinearStateSpaceModel()),
        ],
        n_steps=3,
    )
    booster.set_params(lin=LinearStateSpaceModel(n_steps=2))
    with pytest.raises(
        ValueError, match=r"windows of 3 steps, not 2: set lin__n_steps=3"
    ):
        booster.fit(X, y)


def test_n_steps_message_without_evidence_leads_with_the_default():
    """Shuffled rows do not tell; the booster's default n_steps=1 is named first."""
    X, y = _windows(2, shuffle=True)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel(n_steps=2)), ("ridge", Ridge())]
    )
    with pytest.raises(ValueError) as info:
        booster.fit(X, y)
    message = str(info.value)
    assert message.index("set n_steps=2 on the booster") < message.index(
        "set physics__n_steps=1"
    )


def test_n_steps_message_when_booster_and_stages_agree_but_the_rows_do_not():
    """Everything left at n_steps=1 on windows of 2 steps: name every value to set."""
    X, y = _windows(2)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel()), ("ridge", Ridge())]
    )
    with pytest.raises(
        ValueError,
        match=r"continue each other as windows of 2 steps: set n_steps=2 on the "
        r"booster and on its windowed stages \(physics__n_steps=2\)",
    ):
        booster.fit(X, y)
    booster.set_params(n_steps=2, physics__n_steps=2).fit(X, y)
