"""Measured benchmarks in ``skhybrid run``: splits, model zoo, published figures.

Each system loads its benchmark files from a folder the user names (``--data``),
uses the official split and initialisation window of the ``nonlinear-benchmarks``
loader (v1.0.1), fits every model on the estimation record only, simulates it in
free run on each test record from the first ``n_init`` measured outputs, and scores
``RMSE(y[n_init:], y_model[n_init:])`` in the official units. Every choice (window
and segment lengths, the state-space hybrid's horizon, the model quoted) is made
on a validation tail of the estimation record (its last 25 %), never on a test
record; the zoo itself is in :mod:`skhybrid.experiments._measured_zoo`.
"""

import json
import time
from pathlib import Path

import numpy as np

from skhybrid.datasets import load_cascaded_tanks, load_emps, load_silverbox
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.experiments._greybox import (
    emps_physics,
    silverbox_physics,
    tanks_physics,
    with_next_input,
)
from skhybrid.experiments._measured_zoo import _rmse, fit_zoo

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
    #: Candidate samples per segment of the physics' simulation-error fit
    #: (multiple shooting; None: one free run), chosen on the validation tail.
    segments = (None,)
    #: Maps record inputs to the physics' inputs (None: the same).
    physics_inputs = None
    #: Records the state-space hybrid's training part is cut into.
    hybrid_records = 4

    def load(self, data, quick=False):
        """Return ``(train, tests, bunch)``; train and tests are ``(u, y)`` pairs."""
        raise NotImplementedError

    def physics(self, u, y, dt, quick=False):
        """The unfitted :class:`~skhybrid.domain.StateSpaceModel` of the system."""
        raise NotImplementedError

    def hybrid_candidates(self, quick=False):
        """Settings of the state-space hybrids to try, by label (empty: none)."""
        return {}


def _hybrid(horizon, hidden, *, quick, **extra):
    settings = {
        "horizon": horizon,
        "hidden_layer_sizes": hidden,
        "encoder_hidden_layer_sizes": (32,),
        "lr": 3e-3,
        "batch_size": 64,
        "max_epochs": 6 if quick else 40,
        "patience": 5,
        "validation_fraction": 0.2,
    }
    settings.update(extra)
    return settings


class CascadedTanks(MeasuredSystem):
    name = "cascaded-tanks"
    title = "Cascaded tanks with overflow (measured)"
    unit = "V"

    def load(self, data, quick=False):
        d = load_cascaded_tanks(data)
        s = d.splits
        return (s["train"].u, s["train"].y), {"test": (s["test"].u, s["test"].y)}, d

    def physics(self, u, y, dt, quick=False):
        # Level units are volts of the lower sensor; the upper tank is latent.
        return tanks_physics(dt, max_nfev=40 if quick else 100)


class EMPS(MeasuredSystem):
    name = "emps"
    title = "EMPS electro-mechanical positioning axis (measured, closed loop)"
    unit = "mm"
    scale = 1e3

    def load(self, data, quick=False):
        d = load_emps(data)
        s = d.splits
        return (s["train"].u, s["train"].y), {"test": (s["test"].u, s["test"].y)}, d

    segments = (2000, 4000, 8000)

    def physics(self, u, y, dt, quick=False):
        # The reference model of the description: symmetric friction and an offset.
        return emps_physics(dt, max_nfev=20 if quick else 60)

    def hybrid_candidates(self, quick=False):
        # The network corrects the velocity's update from the velocity and the
        # input (the position drifts over the record, so it is not read).
        common = {
            "correction_states": ["velocity (latent)"],
            "corrected_states": ["velocity (latent)"],
            "encoder_absolute": False,
        }
        if quick:
            quick_one = _hybrid(100, (16, 16), quick=True, stride=50, **common)
            return {"T=100, (16, 16)": quick_one}
        return {
            f"T={T}, {h}": _hybrid(T, h, quick=False, stride=stride, **common)
            for T, h, stride in ((100, (32, 32), 25), (400, (32, 32), 50))
        }


class Silverbox(MeasuredSystem):
    name = "silverbox"
    title = "Silverbox electronic Duffing oscillator (measured)"
    unit = "mV"
    scale = 1e3
    segments = (512,)
    physics_inputs = staticmethod(with_next_input)
    hybrid_records = 6

    def load(self, data, quick=False):
        d = load_silverbox(data)
        s = d.splits
        train = s["train"]
        n = 16384 if quick else len(train.u)
        tests = {k: (s[k].u, s[k].y) for k in ("test_multisine", "test_arrow_full")}
        return (train.u[:n], train.y[:n]), tests, d

    def physics(self, u, y, dt, quick=False):
        return silverbox_physics(dt, u, y, max_nfev=15 if quick else 30)

    def hybrid_candidates(self, quick=False):
        common = {"corrected_states": ["derivative (latent)"]}
        if quick:
            quick_one = _hybrid(50, (16, 16), quick=True, stride=50, **common)
            return {"T=50, (16, 16)": quick_one}
        return {
            f"T={T}, {h}": _hybrid(T, h, quick=False, stride=stride, **common)
            for T, h, stride in ((50, (32, 32), 50), (200, (32, 32), 100))
        }


MEASURED_SYSTEMS = {cls.name: cls() for cls in (CascadedTanks, EMPS, Silverbox)}


def _hull_exit(train, test, n_init):
    """First test index whose ``[y(t), y(t-1), u(t)]`` leaves the training hull."""
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
    models, notes, fit_time, validation = fit_zoo(
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
            except (SimulationDivergedError, FloatingPointError, ValueError) as exc:
                scores[split][label] = float("nan")
                notes.setdefault(label, {})["diverged_on_" + split] = str(exc)
            log(f"  {split:16s} {label:18s} {scores[split][label]:9.4f} {system.unit}")
    hull = {}
    if "test_arrow_full" in tests:
        first, count = _hull_exit(train, tests["test_arrow_full"], n_init)
        hull = {"test_arrow_full": {"first_outside": first, "n_outside": count}}
    physics = models["physics"]
    # The model to quote: the lowest free-run RMSE on the validation tail.
    selected = min(validation, key=validation.get)
    log(f"  selected on the validation tail: {selected}")
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
        "validation_rmse": validation,
        "selected_model": selected,
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
    for j, (split, (_u, y)) in enumerate(tests.items()):
        t = np.arange(len(y)) * dt
        top, bottom = axes[0, j], axes[1, j]
        top.plot(t, system.scale * np.ravel(y), "k", lw=1.0, label="measured")
        errors = {}
        for i, (label, pred) in enumerate(sims[split].items()):
            top.plot(t, system.scale * pred, lw=0.8, label=label, color=f"C{i}")
            err = system.scale * (pred - np.ravel(y))
            err[:n_init] = np.nan
            # The black-box models' errors can be 100 times larger: the error
            # panel shows the physics-based ones, the largest drawn first.
            if label.startswith(("physics", "state-space")):
                errors[label] = (i, err)
        order = sorted(errors, key=lambda k: -np.nanmean(errors[k][1] ** 2))
        for label in order:
            i, err = errors[label]
            bottom.plot(t, err, lw=0.6, label=label, color=f"C{i}")
        bottom.legend(fontsize=7)
        for ax in (top, bottom):
            ax.axvspan(0, n_init * dt, color="0.9")
            if split in hull and hull[split]["first_outside"] is not None:
                ax.axvline(hull[split]["first_outside"] * dt, color="r", ls="--")
        top.set_title(f"{system.title}: {split}")
        unit = system.unit
        top.set_ylabel(f"output [{unit}]")
        bottom.set_ylabel(f"simulation error [{unit}]\n(physics-based models)")
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
            rows.append(
                f"<tr><td>{split}</td><td>{model}</td><td>{value:.4g}</td><td>ours</td></tr>"
            )
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
<title>{results["title"]}</title></head><body>
<h1>{results["title"]}</h1>
<p>Free-run simulation RMSE on the official test record(s) [{unit}], the first
{results["n_init"]} measured samples initialise the state (official protocol).
Every model was fitted on the estimation record only; every choice (window and
segment lengths, the hybrid's horizon T, the model quoted) was made on its last
25 %, with the candidates fitted on the first 75 %.
quick = {results["quick"]}, seed = {results["seed"]},
{results["wall_time_s"]:.0f} s.</p>
<table border="1" cellpadding="3"><tr><th>test</th><th>model</th>
<th>RMSE [{unit}]</th><th>source</th></tr>
{"".join(rows)}</table>
<p>Chosen on the validation tail of the estimation record (never on a test
record): <b>{results["selected_model"]}</b>.</p>
<p>Physics parameters: {params}</p>
<img src="{figure}" style="max-width:100%">
</body></html>"""
    Path(path).write_text(html)
