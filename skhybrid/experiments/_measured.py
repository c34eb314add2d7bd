"""Measured benchmarks in ``skhybrid run``: official splits, model zoo, published figures.

Each system loads its benchmark files from a folder the user names (``--data``),
uses the official split and initialisation window of the ``nonlinear-benchmarks``
loader (v1.0.1), fits every model on the estimation record only, simulates it in
free run on each test record from the first ``n_init`` measured outputs, and scores
``RMSE(y[n_init:], y_model[n_init:])`` in the official units. Model choices (window
lengths) are made on a validation tail of the estimation record (its last 25 %),
never on a test record.
"""

import json
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skhybrid.datasets import load_cascaded_tanks, load_emps, load_silverbox
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.experiments._greybox import (
    OutputErrorModel,
    duffing_output,
    duffing_step,
    emps_output,
    emps_step,
    tanks_output,
    tanks_step,
)
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import simulate

__all__ = ["MEASURED_SYSTEMS", "PUBLISHED", "run_measured"]

#: Published free-run test RMSE in the official units, with sources (data README).
PUBLISHED = {
    "cascaded-tanks": {
        "test": {
            "linear (LTI SS)": (0.588, "Champneys et al. 2024, arXiv:2405.10779"),
            "best baseline (GRU)": (0.396, "Champneys et al. 2024, arXiv:2405.10779"),
            "CT-SUBNET": (0.306, "Beintema et al., ICLR 2023"),
            "state of the art (grey-box with overflow)": (
                0.191,
                "Worden et al. 2018",
            ),
        }
    },
    "emps": {
        "test": {
            "linear (LTI SS)": (5.53, "Champneys et al. 2024, arXiv:2405.10779"),
            "best baseline (polynomial NARX)": (
                5.17,
                "Champneys et al. 2024, arXiv:2405.10779",
            ),
            "CT-SUBNET": (4.61, "Beintema et al., ICLR 2023"),
            "state of the art (dynoNet)": (2.64, "Forgione & Piga 2021"),
        }
    },
    "silverbox": {
        "test_multisine": {
            "linear (LTI SS)": (6.96, "Champneys et al. 2024, arXiv:2405.10779"),
            "best baseline (GP-NARX)": (0.301, "Champneys et al. 2024"),
            "state of the art (DT-SUBNET)": (0.36, "Beintema et al. 2021"),
        },
        "test_arrow_full": {
            "linear (LTI SS)": (14.4, "Champneys et al. 2024, arXiv:2405.10779"),
            "best baseline (GP-NARX)": (0.60, "Champneys et al. 2024"),
            "state of the art (DT-SUBNET)": (1.4, "Beintema et al. 2021"),
        },
    },
}


class MeasuredSystem:
    """A measured benchmark: loader, official split, physics and units."""

    name = ""
    title = ""
    unit = ""
    #: Factor from the data's units to the official reporting units.
    scale = 1.0

    def load(self, data, quick=False):
        """Return ``(train, tests, n_init)``; train and tests are ``(u, y)`` pairs."""
        raise NotImplementedError

    def physics(self, y_train, dt, quick=False):
        raise NotImplementedError


class CascadedTanks(MeasuredSystem):
    name = "cascaded-tanks"
    title = "Cascaded tanks with overflow (measured)"
    unit = "V"

    def load(self, data, quick=False):
        d = load_cascaded_tanks(data)
        s = d.splits
        return (s["train"].u, s["train"].y), {"test": (s["test"].u, s["test"].y)}, d

    def physics(self, y_train, dt, quick=False):
        # Level units are arbitrary (only the output is measured); x1 starts mid-range.
        return OutputErrorModel(
            lambda x, u, p: tanks_step(x, u, p, dt=dt),
            tanks_output,
            {
                "k1": 0.05, "k2": 0.05, "k3": 0.05, "k4": 0.03, "x1max": 6.0,
                "kof": 0.3, "k5": 0.001, "k6": 0.001, "y_offset": 0.5,
            },
            bounds={
                "k1": (1e-4, 1), "k2": (1e-4, 1), "k3": (1e-4, 1), "k4": (1e-4, 1),
                "x1max": (1.0, 100.0), "kof": (0.0, 1.0), "k5": (0.0, 1.0),
                "k6": (0.0, 1.0), "y_offset": (-3.0, 3.0),
            },
            x0=[5.0, float(y_train[0, 0])],
            state_names=["upper level (latent)", "lower level"],
            max_nfev=40 if quick else 100,
        )


class EMPS(MeasuredSystem):
    name = "emps"
    title = "EMPS electro-mechanical positioning axis (measured, closed loop)"
    unit = "mm"
    scale = 1e3

    def load(self, data, quick=False):
        d = load_emps(data)
        s = d.splits
        return (s["train"].u, s["train"].y), {"test": (s["test"].u, s["test"].y)}, d

    def physics(self, y_train, dt, quick=False):
        # The reference model of the description: symmetric friction and an offset.
        return OutputErrorModel(
            lambda x, u, p: emps_step(x, u, p, dt=dt),
            emps_output,
            {"M": 95.0, "Fv": 200.0, "Fc": 20.0, "offset": -3.0},
            bounds={"M": (1.0, 1e3), "Fv": (0.0, 1e4), "Fc": (0.0, 1e3)},
            x0=[float(y_train[0, 0]), 0.0],
            state_names=["position", "velocity (latent)"],
            x0_from_y=lambda y: np.array([y[0], 0.0]),
            max_nfev=20 if quick else 60,
        )


class Silverbox(MeasuredSystem):
    name = "silverbox"
    title = "Silverbox electronic Duffing oscillator (measured)"
    unit = "mV"
    scale = 1e3

    def load(self, data, quick=False):
        d = load_silverbox(data)
        s = d.splits
        train = s["train"]
        n = 16384 if quick else len(train.u)
        tests = {
            k: (s[k].u, s[k].y) for k in ("test_multisine", "test_arrow_full")
        }
        return (train.u[:n], train.y[:n]), tests, d

    def physics(self, y_train, dt, quick=False):
        # Start from a second-order linear fit (poles mapped to continuous time).
        return _DuffingFromARX(dt, max_nfev=20 if quick else 30)


class _DuffingFromARX(OutputErrorModel):
    """Duffing physics whose linear part is initialised by an ARX(2, 2) fit."""

    def __init__(self, dt, max_nfev):
        self.dt = dt
        super().__init__(
            lambda x, u, p: duffing_step(x, u, p, dt=dt),
            duffing_output,
            {"k": 1.0, "d": 1.0, "a": 1.0, "b": 0.0, "y_offset": 0.0},
            x0=[0.0, 0.0],
            state_names=["output", "derivative (latent)"],
            x0_from_y=lambda y: np.array([y[0], (y[1] - y[0]) / dt]),
            max_nfev=max_nfev,
        )

    def fit(self, u, y):
        u0, y0 = np.ravel(u), np.ravel(y)
        A = np.column_stack([y0[1:-1], y0[:-2], u0[1:-1], u0[:-2], np.ones(len(y0) - 2)])
        th = np.linalg.lstsq(A, y0[2:], rcond=None)[0]
        s = np.log(np.roots([1, -th[0], -th[1]]).astype(complex)) / self.dt
        a = float(abs(s[0] * s[1]))
        gain = (th[2] + th[3]) / (1 - th[0] - th[1])
        self.params = {
            "k": gain * a, "d": float(-(s[0] + s[1]).real), "a": a, "b": 0.0,
            "y_offset": float(np.mean(y0)),
        }
        return super().fit(u, y)


MEASURED_SYSTEMS = {cls.name: cls() for cls in (CascadedTanks, EMPS, Silverbox)}


def _rmse(y, pred, n_init):
    return float(np.sqrt(np.mean((np.ravel(y)[n_init:] - np.ravel(pred)[n_init:]) ** 2)))


def _windows(columns, n):
    """Rows ``[c(t-n+1..t) for each column]`` for every t, edge-padded at the start."""
    X = np.column_stack(columns)
    padded = np.vstack([np.repeat(X[:1], n - 1, axis=0), X])
    view = np.lib.stride_tricks.sliding_window_view(padded, n, axis=0)
    return view.reshape(len(X), -1)


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


def _tail_split(u, y, fraction=0.25):
    cut = int(len(u) * (1 - fraction))
    return (u[:cut], y[:cut]), (u[cut:], y[cut:])


def _select_narx(make, u, y, n_init, candidates, notes, label):
    """The window length whose model simulates the validation tail best."""
    (u_a, y_a), (u_b, y_b) = _tail_split(u, y)
    scores = {}
    for n in candidates:
        try:
            model = make(n).fit(u_a, y_a)
            pred = model.simulate(u_b, y_b[: max(n_init, n)])
            scores[n] = _rmse(y_b, pred, max(n_init, n))
        except (SimulationDivergedError, ValueError, FloatingPointError):
            scores[n] = float("inf")
    best = min(scores, key=scores.get)
    notes[label] = {"validation_rmse": {str(k): v for k, v in scores.items()}, "n": best}
    return make(best).fit(u, y)


def _fit_zoo(system, train, n_init, dt, *, quick, seed, log):
    """Fit every model on the estimation record; return ``{name: model}``, notes."""
    u, y = train
    models, notes, fit_time = {}, {}, {}

    start = time.perf_counter()
    physics = system.physics(y, dt, quick=quick)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        physics.fit(u, y)
    models["physics"] = physics
    fit_time["physics"] = time.perf_counter() - start
    log(f"  physics fitted in {fit_time['physics']:.1f} s")

    lags = (2, 4, 8) if not quick else (2, 4)
    start = time.perf_counter()
    models["linear ARX"] = _select_narx(
        lambda n: _NARX(Ridge(alpha=1e-6), n), u, y, n_init, lags, notes, "linear ARX"
    )
    fit_time["linear ARX"] = time.perf_counter() - start

    start = time.perf_counter()
    n_lin = notes["linear ARX"]["n"]
    models["dense NARX"] = _NARX(_dense(quick, seed), n_lin).fit(u, y)
    notes["dense NARX"] = {"n": n_lin, "chosen": "the linear ARX's window"}
    fit_time["dense NARX"] = time.perf_counter() - start
    log(f"  dense NARX fitted in {fit_time['dense NARX']:.1f} s")

    # Hybrids: the physics' free run on the estimation record, from its fitted x0.
    y_phys = physics.simulate(u, y[:n_init])[:, 0]
    (u_a, y_a), (u_b, y_b) = _tail_split(u, y)
    cut = len(u_a)
    for label, make in (
        ("physics + linear", lambda: Ridge(alpha=1e-3)),
        ("physics + dense", lambda: _dense(quick, seed)),
    ):
        start = time.perf_counter()
        scores = {}
        for n in (1, 10, 50) if not quick else (1, 10):
            corr = _PhysicsCorrection(physics, make(), n)
            corr.fit_on_physics(u_a, y_a, y_phys[:cut])
            pred = corr.correct(u_b, y_phys[cut:])
            scores[n] = _rmse(y_b, pred, 0)
        # The physics alone on the same tail is the bar a correction must clear.
        scores_phys = _rmse(y_b, y_phys[cut:], 0)
        best = min(scores, key=scores.get)
        notes[label] = {
            "validation_rmse": {str(k): v for k, v in scores.items()},
            "validation_rmse_physics_alone": scores_phys,
            "n": best,
        }
        models[label] = _PhysicsCorrection(physics, make(), best).fit_on_physics(
            u, y, y_phys
        )
        fit_time[label] = time.perf_counter() - start
        log(f"  {label} fitted in {fit_time[label]:.1f} s")
    return models, notes, fit_time


def _hull_exit(train, test, n_init):
    """First test index whose window ``[y(t), y(t-1), u(t)]`` leaves the training hull."""
    from skhybrid.model_selection import in_convex_hull

    def rows(u, y):
        y = np.ravel(y)
        return np.column_stack([y[1:], y[:-1], np.ravel(u)[1:]])

    inside = in_convex_hull(rows(*test), rows(*train))
    outside = np.flatnonzero(~inside) + 1
    return (int(outside[0]) if outside.size else None), int(outside.size)


def run_measured(name, data, out, *, quick=False, seed=0, log=print):
    """Fit the zoo on a measured system, score it, and write the report to ``out``.

    Parameters
    ----------
    name : str
        One of :data:`MEASURED_SYSTEMS`.
    data : str or pathlib.Path
        Folder holding the benchmark files (for example ``../shared/data``).
    out : str or pathlib.Path
        Output folder: ``results.json``, ``report.html`` and ``<name>.png``.
    quick : bool, default=False
        Shorter fits (and a shorter Silverbox estimation record).
    seed : int, default=0
        Seed of the networks.
    log : callable, default=print
        Receives progress lines.

    Returns
    -------
    results : dict
        The content of ``results.json``.
    """
    if name not in MEASURED_SYSTEMS:
        raise ValueError(
            f"name must be one of {sorted(MEASURED_SYSTEMS)}; got name={name!r}."
        )
    system = MEASURED_SYSTEMS[name]
    wall = time.perf_counter()
    train, tests, bunch = system.load(data, quick=quick)
    n_init, dt = bunch.n_init, bunch.dt
    log(f"{system.title}: {len(train[0])} estimation samples, n_init = {n_init}")
    models, notes, fit_time = _fit_zoo(
        system, train, n_init, dt, quick=quick, seed=seed, log=log
    )
    sims, scores = {}, {}
    for split, (u, y) in tests.items():
        sims[split], scores[split] = {}, {}
        for label, model in models.items():
            try:
                pred = np.ravel(model.simulate(u, y[:n_init]))
                scores[split][label] = system.scale * _rmse(y, pred, n_init)
                sims[split][label] = pred
            except (SimulationDivergedError, FloatingPointError) as exc:
                scores[split][label] = float("nan")
                notes.setdefault(label, {})["diverged_on_" + split] = str(exc)
            log(f"  {split:16s} {label:18s} {scores[split][label]:9.4f} {system.unit}")
    hull = {}
    if "test_arrow_full" in tests:
        first, count = _hull_exit(train, tests["test_arrow_full"], n_init)
        hull = {"test_arrow_full": {"first_outside": first, "n_outside": count}}
    physics = models["physics"]
    results = {
        "system": name,
        "title": system.title,
        "unit": system.unit,
        "quick": quick,
        "seed": seed,
        "n_init": n_init,
        "dt": dt,
        "n_train": len(train[0]),
        "test_rmse": scores,
        "published": {
            split: {k: {"rmse": v, "source": s} for k, (v, s) in pub.items()}
            for split, pub in PUBLISHED[name].items()
        },
        "physics_params": physics.params_,
        "physics_params_std": physics.params_std_,
        "selection": notes,
        "fit_time_s": fit_time,
        "hull": hull,
        "wall_time_s": time.perf_counter() - wall,
    }
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figure = _figure(system, tests, sims, n_init, dt, hull, out / f"{name}.png")
    (out / "results.json").write_text(json.dumps(results, indent=2, default=float))
    _html(results, figure.name, out / "report.html")
    log(f"wrote {out / 'report.html'} ({results['wall_time_s']:.1f} s)")
    return results


def _figure(system, tests, sims, n_init, dt, hull, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        2, len(tests), figsize=(7 * len(tests), 6), sharex="col", squeeze=False
    )
    for j, (split, (u, y)) in enumerate(tests.items()):
        t = np.arange(len(y)) * dt
        top, bottom = axes[0, j], axes[1, j]
        top.plot(t, system.scale * np.ravel(y), "k", lw=1.0, label="measured")
        for label, pred in sims[split].items():
            top.plot(t, system.scale * pred, lw=0.8, label=label)
            err = system.scale * (pred - np.ravel(y))
            err[:n_init] = np.nan
            bottom.plot(t, err, lw=0.6, label=label)
        for ax in (top, bottom):
            ax.axvspan(0, n_init * dt, color="0.9")
            if split in hull and hull[split]["first_outside"] is not None:
                ax.axvline(hull[split]["first_outside"] * dt, color="r", ls="--")
        top.set_title(f"{system.title}: {split}")
        unit = system.unit
        top.set_ylabel(f"output [{unit}]")
        bottom.set_ylabel(f"simulation error [{unit}]")
        bottom.set_xlabel("time [s] (grey: init window; red: leaves the training hull)")
        top.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def _html(results, figure, path):
    unit = results["unit"]
    rows = []
    for split, scores in results["test_rmse"].items():
        for model, value in scores.items():
            rows.append(f"<tr><td>{split}</td><td>{model}</td><td>{value:.4g}</td><td>ours</td></tr>")
        for label, entry in results["published"].get(split, {}).items():
            rows.append(
                f"<tr><td>{split}</td><td>{label}</td><td>{entry['rmse']:.4g}</td>"
                f"<td>{entry['source']}</td></tr>"
            )
    params = ", ".join(
        f"{k} = {v:.5g} &plusmn; {results['physics_params_std'][k]:.2g}"
        for k, v in results["physics_params"].items()
    )
    html = f"""<!doctype html><html><head><meta charset="utf-8">
<title>{results['title']}</title></head><body>
<h1>{results['title']}</h1>
<p>Free-run simulation RMSE on the official test record(s) [{unit}], the first
{results['n_init']} measured samples initialise the state (official protocol).
Every model was fitted on the estimation record only; window lengths were chosen on
its last 25 %. quick = {results['quick']}, seed = {results['seed']},
{results['wall_time_s']:.0f} s.</p>
<table border="1" cellpadding="3"><tr><th>test</th><th>model</th>
<th>RMSE [{unit}]</th><th>source</th></tr>
{''.join(rows)}</table>
<p>Physics parameters: {params}</p>
<img src="{figure}" style="max-width:100%">
</body></html>"""
    Path(path).write_text(html)
