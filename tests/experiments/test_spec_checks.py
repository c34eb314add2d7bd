"""A SystemSpec is checked when it is built, every field, naming the parameter.

And the test records given as data are checked with the estimation records,
before any fit, naming the record.
"""

import re

import numpy as np
import pandas as pd
import pytest

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments import SystemSpec


def first_order(x, u, *, xp, a, b):
    return a * x + b * u


def _physics():
    return StateSpaceModel(
        first_order, {"a": 0.5, "b": 1.0}, state_names=["y"], time="discrete"
    )


def _record(n=200, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 1))
    return u, 0.5 * u


def _spec(**kwargs):
    options = dict(
        name="first-order",
        records=[_record()],
        physics=_physics(),
        n_init=5,
        dt=0.1,
        tests={"test": _record(100, 1)},
    )
    options.update(kwargs)
    return SystemSpec(**options)


def _frame(n, period):
    u, y = _record(n)
    index = pd.to_timedelta(np.arange(n) * period, unit="s")
    return pd.DataFrame({"force": u[:, 0], "position": y[:, 0]}, index=index)


def test_a_good_spec_is_built():
    spec = _spec()
    assert spec.sample_period() == 0.1


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"dt": True}, ValueError, "dt must be a positive number; got dt=True"),
        ({"dt": float("nan")}, ValueError, "got dt=nan"),
        ({"scale": float("inf")}, ValueError, "scale must be positive; got scale=inf"),
        ({"scale": float("nan")}, ValueError, "got scale=nan"),
        ({"scale": -1.0}, ValueError, "got scale=-1.0"),
        ({"scale": 0}, ValueError, "got scale=0"),
        (
            {"published": "abc"},
            TypeError,
            "published must be a dict {test name: {label:",
        ),
        ({"published": {"test": {"x": 0.3}}}, TypeError, "got published="),
        ({"published": {"test": ("x", 0.3)}}, TypeError, "got published="),
        (
            {"hybrids": {"T": {"bogus": 1}}},
            ValueError,
            "hybrids['T'] has settings ['bogus'] that are not",
        ),
        ({"hybrids": {"T": {"horizn": 20}}}, ValueError, "did you mean 'horizon'?"),
        ({"hybrids": {"T": {"random_state": 3}}}, ValueError, "set by the run"),
        ({"hybrids": {"T": 20}}, TypeError, "hybrids['T'] must be a dict"),
        (
            {"hybrid_records": "a"},
            ValueError,
            "must be an int >= 1; got hybrid_records='a'",
        ),
        ({"hybrid_records": 0}, ValueError, "got hybrid_records=0"),
        ({"hybrid_records": -2}, ValueError, "got hybrid_records=-2"),
        ({"hybrid_records": True}, ValueError, "got hybrid_records=True"),
        ({"physics_inputs": 5}, TypeError, "physics_inputs must be a callable"),
        ({"segments": 5}, ValueError, "or None); got segments=5"),
        ({"segments": "whole"}, ValueError, "got segments='whole'"),
        ({"segments": ()}, ValueError, "got segments=()"),
        ({"segments": (None, 2.5)}, ValueError, "got segments=(None, 2.5)"),
        ({"title": 3}, TypeError, "title must be a str; got title=3"),
        ({"unit": None}, TypeError, "unit must be a str; got unit=None"),
        ({"notes": ["a"]}, TypeError, "notes must be a str"),
        ({"inputs": "force"}, TypeError, "names or None; got inputs='force'"),
        ({"outputs": []}, TypeError, "got outputs=[]"),
        (
            {"score_from_estimation_start": "yes"},
            TypeError,
            "score_from_estimation_start must be a bool",
        ),
        ({"records": 5}, TypeError, "records must be a (u, y) pair"),
        (
            {"physics": StateSpaceModel},
            TypeError,
            (
                "physics is the class StateSpaceModel, not a model: pass an "
                "unfitted instance, physics=StateSpaceModel(...)"
            ),
        ),
        (
            {"physics_starts": [{"aa": 1.0}]},
            ValueError,
            (
                "physics_starts[0]['aa']: 'aa' is not a parameter of the physics "
                "(did you mean 'a'?); its parameters are ['a', 'b']"
            ),
        ),
        (
            {"physics_starts": [{"a": 0.2}, {"b": float("nan")}]},
            ValueError,
            "physics_starts[1]['b'] must be a finite number; got nan",
        ),
        (
            {"physics_starts": [{"a": "1"}]},
            ValueError,
            "physics_starts[0]['a'] must be a finite number; got '1'",
        ),
        (
            {
                "physics": _physics().set_params(bounds={"a": (0.0, 1.0)}),
                "physics_starts": [{"a": 2.0}],
            },
            ValueError,
            "physics_starts[0]['a']=2.0 is outside the physics' bounds [0.0, 1.0]",
        ),
    ],
)
def test_a_bad_field_is_refused_when_built(kwargs, error, words):
    with pytest.raises(error, match=re.escape(words)):
        _spec(**kwargs)


def test_a_callable_physics_starts_are_checked_when_it_is_built():
    spec = _spec(physics=lambda U, Y, dt: _physics(), physics_starts=[{"c": 1.0}])
    U, Y = spec.estimation_records()
    with pytest.raises(ValueError, match=r"physics_starts\[0\]\['c'\]"):
        spec.make_physics(U, Y, 0.1)


def test_records_sampled_at_different_periods_are_refused():
    frames = [_frame(200, 0.1), _frame(200, 0.2)]
    with pytest.raises(ValueError, match=r"different sample periods \(0\.1, 0\.2 s\)"):
        _spec(
            records=frames, dt=None, inputs=["force"], outputs=["position"], tests=None
        )
    # One period: read from the index.
    spec = _spec(
        records=frames[:1], dt=None, inputs=["force"], outputs=["position"], tests=None
    )
    assert spec.sample_period() == pytest.approx(0.1)


def test_strings_in_a_record_name_the_record():
    u, y = _record()
    u_text = u.astype(object)
    u_text[3, 0] = "1,5"
    with pytest.raises(
        ValueError,
        match=r"records\[1\] must hold numbers; its "
        "inputs do not",
    ):
        _spec(records=[(u, y), (u_text, y)])
    frame = _frame(200, 0.1).astype(object)
    frame.iloc[4, 1] = "n/a"
    with pytest.raises(
        ValueError,
        match=r"records\[0\] must hold numbers; its "
        "outputs do not",
    ):
        _spec(records=[frame], inputs=["force"], outputs=["position"], tests=None)


def test_a_test_record_of_other_columns_is_refused_before_any_fit():
    u, y = _record(100, 1)
    with pytest.raises(
        ValueError,
        match=re.escape(
            "tests['test'] has inputs of shape (100, 2) and outputs of shape "
            "(100, 1); the estimation records have 1 input and 1 output column(s)"
        ),
    ):
        _spec(tests={"test": (np.hstack([u, u]), y)})


def test_a_test_record_holding_nan_is_refused_before_any_fit():
    u, y = _record(100, 1)
    y = y.copy()
    y[7] = np.nan
    with pytest.raises(ValueError, match=r"tests\['test'\] holds NaN"):
        _spec(tests={"test": (u, y)})


def test_a_nan_is_located_by_record_row_and_column():
    u, y = _record(100, 1)
    y = y.copy()
    y[37] = np.nan
    y[60] = np.inf
    with pytest.raises(
        ValueError,
        match=r"records\[1\] holds NaN or infinite values \(the first at row 37, "
        r"outputs column 0: nan; 2 in all\); remove or interpolate",
    ):
        _spec(records=[_record(), (u, y)])
    frame = pd.DataFrame(
        {"force": np.r_[np.zeros(12), np.nan, np.zeros(87)], "position": y[:, 0]},
        index=pd.to_timedelta(np.arange(100) * 0.1, unit="s"),
    )
    with pytest.raises(ValueError, match=r"row 12, inputs column 0 \('force'\)"):
        _spec(records=frame, inputs=["force"], outputs=["position"], dt=None)


def test_test_records_of_callable_records_are_checked_when_read():
    u, y = _record(100, 1)
    spec = _spec(records=lambda: [_record()], tests={"test": (np.hstack([u, u]), y)})
    with pytest.raises(ValueError, match=r"tests\['test'\] has inputs of shape"):
        spec.estimation_records()


def test_a_bad_spec_through_the_cli_is_one_line(tmp_path, monkeypatch, capsys):
    from skhybrid.cli import main

    (tmp_path / "bad_spec.py").write_text(
        "from skhybrid.experiments import SystemSpec\n"
        "from skhybrid.domain import StateSpaceModel\n"
        "spec = SystemSpec('x', records=5, physics=StateSpaceModel(lambda x, u, *, "
        "xp, a: a * x, {'a': 0.5}, state_names=['y'], time='discrete'), n_init=5, "
        "dt=0.1)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--system", "bad_spec:spec", "--out", "out"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "--system bad_spec:spec: records must be a (u, y) pair" in err
