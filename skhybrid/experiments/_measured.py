"""Measured benchmarks as systems of ``skhybrid run``: data, zoo hooks, report.

A measured benchmark runs through the same pipeline as the paper's simulated
systems (:func:`~skhybrid.experiments.run_experiment`, the run folder with its
lock and resume, joblib or Dask, progress, :func:`write_report`); what is its own
is data and hooks of its :class:`MeasuredSystem`:

- it loads its benchmark files from a folder the user names (``--data``), with
  the official split and initialisation window of the ``nonlinear-benchmarks``
  loader (v1.0.1);
- its zoo (:mod:`skhybrid.experiments._measured_zoo`) fits every model on the
  estimation record only, choosing every candidate (window and segment lengths,
  the state-space hybrid's horizon) on a validation tail of that record (its
  last 25 %), never on a test record;
- each model is simulated in free run on each test record from the first
  ``n_init`` measured outputs and scored by ``RMSE(y[n_init:],
  y_model[n_init:])`` in the official units, beside the published figures.
"""

import base64
import html
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from skhybrid.datasets import (
    fetch_cascaded_tanks,
    fetch_emps,
    fetch_silverbox,
    load_cascaded_tanks,
    load_emps,
    load_silverbox,
)
from skhybrid.experiments._measured_physics import (
    emps_physics,
    silverbox_physics,
    tanks_physics,
    with_next_input,
)
from skhybrid.experiments._measured_zoo import (
    MeasuredContext,
    _rmse,
    fit_model,
    zoo,
)

__all__ = [
    "MEASURED_SYSTEMS",
    "PUBLISHED",
    "MeasuredResult",
    "MeasuredSettings",
    "MeasuredSystem",
    "run_measured",
]

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
            "DT-SUBNET": (1.4, "Beintema et al. 2021"),
            "state of the art (PNLSS)": (0.26, "Paduart et al. 2010"),
        },
        "test_arrow_no_extrapolation": {
            "linear (LTI SS)": (6.58, "Champneys et al. 2024, arXiv:2405.10779"),
            "DT-SUBNET": (0.32, "Beintema et al. 2021"),
            "state of the art (GP-NARX)": (0.259, "Champneys et al. 2024"),
        },
    },
}


@dataclass(frozen=True)
class MeasuredSettings:
    """What makes two runs of a measured benchmark the same.

    Parameters
    ----------
    quick : bool, default=False
        Shorter fits, fewer candidates (and a shorter Silverbox estimation
        record).
    seed : int, default=0
        Seed of the networks.
    """

    quick: bool = False
    seed: int = 0

    def with_seed(self, seed):
        """The same settings with another seed.

        Parameters
        ----------
        seed : int
            Seed of the networks.

        Returns
        -------
        settings : MeasuredSettings
            A copy with ``seed``.
        """
        return replace(self, seed=seed)

    def to_dict(self):
        """The settings as a JSON-ready dict.

        Returns
        -------
        settings : dict
            Every field.
        """
        return asdict(self)


class MeasuredSystem:
    """A measured benchmark: loader, official split, physics, units and zoo hooks.

    The runner calls :meth:`default_settings`, :meth:`new_result`,
    :meth:`model_zoo` and :meth:`job`; subclasses set ``name``, ``title``,
    ``unit`` and ``scale`` and implement :meth:`load` and :meth:`physics`.
    """

    #: Runs on measured records (``--data``), not on simulated splits.
    measured = True
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

    def published(self):
        """The published test figures, ``{split: {label: (rmse, source)}}``."""
        return PUBLISHED.get(self.name, {})

    # -- the runner's hooks ----------------------------------------------------
    def default_settings(self, quick=False, seed=0):
        """The run's settings.

        Parameters
        ----------
        quick : bool, default=False
            Shorter fits.
        seed : int, default=0
            Seed of the networks.

        Returns
        -------
        settings : MeasuredSettings
            ``quick`` and ``seed``.
        """
        return MeasuredSettings(quick=bool(quick), seed=int(seed))

    def new_result(self, settings, data):
        """Load the records and return an empty :class:`MeasuredResult`.

        Parameters
        ----------
        settings : MeasuredSettings
            ``quick`` shortens the Silverbox's estimation record.
        data : str or Path or None
            Folder holding the benchmark files; None fetches them (downloaded
            once into the data home, see
            :func:`skhybrid.datasets.get_data_home`).

        Returns
        -------
        result : MeasuredResult
            The records, ``n_init`` and ``dt``; no model yet.
        """
        train, tests, bunch = self.load(data, quick=settings.quick)
        result = MeasuredResult(self, settings, train, tests, bunch.n_init, bunch.dt)
        if "test_arrow_full" in tests:
            first, count = _hull_exit(train, tests["test_arrow_full"], bunch.n_init)
            result.hull = {
                "test_arrow_full": {"first_outside": first, "n_outside": count}
            }
        return result

    def model_zoo(self, settings):
        """The zoo's models (see :func:`skhybrid.experiments._measured_zoo.zoo`).

        Parameters
        ----------
        settings : MeasuredSettings
            ``quick`` gives fewer candidates.

        Returns
        -------
        zoo : dict of str to ZooModel
            In the order the report lists them.
        """
        return zoo(self, settings.quick)

    def job(self, name, model, result, deps, sink=None):
        """The joblib call that chooses, refits and simulates one model.

        Parameters
        ----------
        name : str
            The model's name.
        model : ZooModel
            Its candidates and fit.
        result : MeasuredResult
            The records and settings.
        deps : dict of str to dict
            The fits of the models it requires.
        sink : object or None, default=None
            Where networks report their epochs.

        Returns
        -------
        call : tuple
            A :func:`joblib.delayed` call of
            :func:`~skhybrid.experiments._measured_zoo.fit_model`.
        """
        from joblib import delayed

        u, y = result.train
        ctx = MeasuredContext(
            self,
            u,
            y,
            int(result.n_init),
            float(result.dt),
            result.settings.quick,
            result.settings.seed,
        )
        return delayed(fit_model)(name, model, ctx, deps, result.tests, sink)


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
        d = fetch_cascaded_tanks() if data is None else load_cascaded_tanks(data)
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
        d = fetch_emps() if data is None else load_emps(data)
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
        d = fetch_silverbox() if data is None else load_silverbox(data)
        s = d.splits
        train = s["train"]
        n = 16384 if quick else len(train.u)
        names = ("test_multisine", "test_arrow_full", "test_arrow_no_extrapolation")
        tests = {k: (s[k].u, s[k].y) for k in names}
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


class MeasuredResult:
    """Everything one run of one measured benchmark produced.

    Parameters
    ----------
    system : MeasuredSystem
        The benchmark.
    settings : MeasuredSettings
        ``quick`` and ``seed``.
    train : tuple of ndarray
        The estimation record ``(u, y)``.
    tests : dict of str to tuple of ndarray
        ``{split: (u, y)}``: the official test records.
    n_init : int
        Samples of the official initialisation window.
    dt : float
        Sample period.

    Attributes
    ----------
    predictions : dict of str to dict of str to ndarray
        ``predictions[split][model]``: the free run over the test record (NaN
        where it failed), in the data's units.
    rows : list of dict
        One row per model and test record (``results.csv``).
    params : dict of str to dict
        Fitted physical parameters and standard errors.
    fits : dict of str to dict
        Fit time, epochs, warnings, validation RMSE and the choices of each
        model.
    hull : dict
        On the Silverbox arrow: the first test sample whose window leaves the
        training hull, and how many do.
    wall_time : float
        Seconds for the whole run.
    """

    def __init__(self, system, settings, train, tests, n_init, dt):
        self.system = system
        self.settings = settings
        self.train = train
        self.tests = tests
        self.n_init = int(n_init)
        self.dt = float(dt)
        self.predictions = {split: {} for split in tests}
        self.rows = []
        self.params = {}
        self.fits = {}
        self.hull = {}
        self.wall_time = float("nan")

    @property
    def test_splits(self):
        return list(self.tests)

    def test_rmse(self, split, model):
        """Free-run RMSE of ``model`` on the test record ``split`` (official units).

        Parameters
        ----------
        split : str
            A test record's name.
        model : str
            A model's name.

        Returns
        -------
        rmse : float
            NaN where the free run failed.
        """
        y = self.tests[split][1]
        return self.system.scale * _rmse(y, self.predictions[split][model], self.n_init)

    def validation_rmse(self):
        """``{model: validation-tail RMSE}`` (official units) of the quoted models."""
        return {
            model: fit["validation_rmse"]
            for model, fit in self.fits.items()
            if fit.get("validation_rmse") is not None
            and np.isfinite(fit["validation_rmse"])
        }

    def selected_model(self):
        """The model to quote: the lowest free-run RMSE on the validation tail."""
        validation = self.validation_rmse()
        return min(validation, key=validation.get) if validation else None

    def model_rows(self, split, model):
        """The scores of one model on one test record, as rows of results.csv.

        Parameters
        ----------
        split : str
            A test record's name.
        model : str
            A model's name.

        Returns
        -------
        rows : list of dict
            One row (the benchmarks have one output).
        """
        fit = self.fits.get(model, {})
        return [
            {
                "system": self.system.name,
                "seed": self.settings.seed,
                "model": model,
                "split": split,
                "output": "y",
                "rmse": self.test_rmse(split, model),
                "unit": self.system.unit,
                "validation_rmse": fit.get("validation_rmse"),
                "fit_time_s": fit.get("fit_time"),
                "n_epochs": fit.get("n_epochs"),
            }
        ]

    def summary(self):
        """The system's entry of ``results.json``.

        Returns
        -------
        summary : dict
            Test RMSE by record and model, the published figures, the physics'
            parameters, the choices, the validation RMSE, the selected model,
            fit times, the hull exit and the rows.
        """
        physics = self.params.get("physics", {})
        return {
            "title": self.system.title,
            "unit": self.system.unit,
            "quick": self.settings.quick,
            "seed": self.settings.seed,
            "settings": self.settings.to_dict(),
            "n_init": self.n_init,
            "dt": self.dt,
            "n_train": len(self.train[0]),
            "test_rmse": {
                split: {model: self.test_rmse(split, model) for model in preds}
                for split, preds in self.predictions.items()
            },
            "published": {
                split: {k: {"rmse": v, "source": s} for k, (v, s) in pub.items()}
                for split, pub in self.system.published().items()
            },
            "physics_params": {k: p["value"] for k, p in physics.items()},
            "physics_params_std": {k: p["std"] for k, p in physics.items()},
            "selection": {k: fit.get("selection") for k, fit in self.fits.items()},
            "validation_rmse": self.validation_rmse(),
            "selected_model": self.selected_model(),
            "fit_time_s": {k: fit.get("fit_time") for k, fit in self.fits.items()},
            "hull": self.hull,
            "wall_time_s": self.wall_time,
            "params": self.params,
            "fits": self.fits,
            "results": self.rows,
        }


def _hull_exit(train, test, n_init):
    """First test index whose ``[y(t), y(t-1), u(t)]`` leaves the training hull."""
    from skhybrid.model_selection import in_convex_hull

    def rows(u, y):
        y = np.ravel(y)
        return np.column_stack([y[1:], y[:-1], np.ravel(u)[1:]])

    inside = in_convex_hull(rows(*test), rows(*train))
    outside = np.flatnonzero(~inside) + 1
    return (int(outside[0]) if outside.size else None), int(outside.size)


def measured_figure(result, out_dir):
    """Draw the test records against each model's free run; return the path.

    Parameters
    ----------
    result : MeasuredResult
        A finished run.
    out_dir : Path
        Where ``<system>.png`` is written.

    Returns
    -------
    path : Path
        The figure's file.
    """
    # The object-oriented Figure API draws without pyplot: no backend is chosen
    # and a user's own plotting session is left alone.
    from matplotlib.figure import Figure

    system, tests, n_init, dt = result.system, result.tests, result.n_init, result.dt
    fig = Figure(figsize=(7 * len(tests), 6))
    axes = fig.subplots(2, len(tests), sharex="col", squeeze=False)
    for j, (split, (_u, y)) in enumerate(tests.items()):
        t = np.arange(len(y)) * dt
        top, bottom = axes[0, j], axes[1, j]
        top.plot(t, system.scale * np.ravel(y), "k", lw=1.0, label="measured")
        errors = {}
        for i, (label, pred) in enumerate(result.predictions[split].items()):
            if not np.all(np.isfinite(pred)):
                continue  # a failed free run is reported in the tables
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
            hull = result.hull.get(split)
            if hull and hull["first_outside"] is not None:
                ax.axvline(hull["first_outside"] * dt, color="r", ls="--")
        top.set_title(f"{system.title}: {split}")
        unit = system.unit
        top.set_ylabel(f"output [{unit}]")
        bottom.set_ylabel(f"simulation error [{unit}]\n(physics-based models)")
        bottom.set_xlabel("time [s] (grey: init window; red: leaves the training hull)")
        top.legend(fontsize=7)
    fig.tight_layout()
    path = Path(out_dir) / f"{system.name}.png"
    fig.savefig(path, dpi=90)
    return path


def measured_section(result, figure):
    """The report's HTML section of a measured run.

    Parameters
    ----------
    result : MeasuredResult
        A finished run.
    figure : Path
        Its figure, embedded in the page.

    Returns
    -------
    section : str
        HTML.
    """
    summary = result.summary()
    unit = html.escape(summary["unit"])
    rows = []
    for split, scores in summary["test_rmse"].items():
        for model, value in scores.items():
            validation = summary["validation_rmse"].get(model)
            rows.append(
                f"<tr><td>{html.escape(split)}</td><td>{html.escape(model)}</td>"
                f"<td>{value:.4g}</td>"
                f"<td>{'' if validation is None else format(validation, '.4g')}</td>"
                "<td>ours</td></tr>"
            )
        for label, entry in summary["published"].get(split, {}).items():
            rows.append(
                f"<tr><td>{html.escape(split)}</td><td>{html.escape(label)}</td>"
                f"<td>{entry['rmse']:.4g}</td><td></td>"
                f"<td>{html.escape(entry['source'])}</td></tr>"
            )
    params = ", ".join(
        f"{html.escape(k)} = {float(v):.5g} &plusmn; "
        f"{float(summary['physics_params_std'][k] or 0.0):.2g}"
        for k, v in summary["physics_params"].items()
        if np.ndim(v) == 0
    )
    data = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
    selected = summary["selected_model"]
    return f"""<h2>{html.escape(summary["title"])}</h2>
<p>Free-run simulation RMSE on the official test record(s) [{unit}], the first
{summary["n_init"]} measured samples initialise the state (official protocol).
Every model was fitted on the estimation record only; every choice (window and
segment lengths, the hybrid's horizon T, the model quoted) was made on its last
25 %, with the candidates fitted on the first 75 %.
quick = {summary["quick"]}, seed = {summary["seed"]},
{summary["wall_time_s"]:.0f} s.</p>
<table><tr><th>test</th><th>model</th><th>RMSE [{unit}]</th>
<th>validation RMSE [{unit}]</th><th>source</th></tr>
{"".join(rows)}</table>
<p>Chosen on the validation tail of the estimation record (never on a test
record): <b>{html.escape(str(selected))}</b>.</p>
<p>Physics parameters: {params}</p>
<h4>Test records and free runs</h4>
<img alt='{html.escape(summary["title"])}' src='data:image/png;base64,{data}'>
"""


def run_measured(name, data, out, *, quick=False, seed=0, n_jobs=1, overwrite=False):
    """Run a measured benchmark into the run folder ``out`` and write its report.

    The same pipeline as ``skhybrid run NAME --data DATA --out OUT``: the folder
    is checked and locked before any fit, finished models are kept as they land,
    and an unfinished run of the same settings in ``out`` is carried on.

    Parameters
    ----------
    name : str
        One of :data:`MEASURED_SYSTEMS`.
    data : str or pathlib.Path
        Folder holding the benchmark files (for example ``../shared/data``).
    out : str or pathlib.Path
        The run folder: ``results.csv``, ``results.json``, ``report.html``,
        ``<name>.png`` and ``models/``.
    quick : bool, default=False
        Shorter fits (and a shorter Silverbox estimation record).
    seed : int, default=0
        Seed of the networks.
    n_jobs : int, default=1
        Models fitted in parallel with joblib.
    overwrite : bool, default=False
        Replace a previous run in ``out``.

    Returns
    -------
    results : dict
        The system's entry of ``results.json``.
    """
    from skhybrid.experiments._report import write_report
    from skhybrid.experiments._runner import run_experiment
    from skhybrid.experiments._store import RunFolder

    if name not in MEASURED_SYSTEMS:
        raise ValueError(
            f"name must be one of {sorted(MEASURED_SYSTEMS)}; got name={name!r}."
        )
    import shlex

    import skhybrid

    system = MEASURED_SYSTEMS[name]
    settings = system.default_settings(quick, seed)
    # The identity and command of `skhybrid run`, so that either carries on a
    # run the other left unfinished.
    identity = {
        "skhybrid": skhybrid.__version__,
        "systems": [name],
        "quick": settings.quick,
        "seed": settings.seed,
        "settings": settings.to_dict(),
    }
    words = ["run", name, "--data", str(data), "--out", str(out)]
    words += ["--quick"] * settings.quick + ["--seed", str(settings.seed)]
    folder = RunFolder(out).prepare()
    try:
        folder.start(identity, "skhybrid " + shlex.join(words), overwrite=overwrite)
        result = run_experiment(
            system, settings=settings, n_jobs=n_jobs, folder=folder, data=data
        )
        write_report([result], folder.path)
        folder.complete()
    finally:
        folder.lock.release()
    return result.summary()
