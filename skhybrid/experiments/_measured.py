"""Measured systems in the pipeline: the built-in benchmarks' specs, the report.

A measured system, a user's or a built-in benchmark, is a
:class:`~skhybrid.experiments.SystemSpec` run through the same pipeline as the
paper's simulated systems (:func:`~skhybrid.experiments.run_experiment`, the run
folder with its lock and resume, joblib or Dask, progress, :func:`write_report`):

- its estimation records are loaded (a built-in benchmark's from the folder the
  user names with ``--data``, or fetched), with the official split and
  initialisation window of the ``nonlinear-benchmarks`` loader (v1.0.1);
- its zoo (:mod:`skhybrid.experiments._measured_zoo`) fits every model on the
  estimation records only, choosing every candidate (window and segment
  lengths, the state-space hybrid's horizon, the model quoted) on validation
  tails of the records (their last 25 %), never on a test record;
- every seed's selection is sealed (:mod:`skhybrid.experiments._sealed`), then
  each model is simulated in free run on each test record from the first
  ``n_init`` measured outputs and scored by ``RMSE(y[n_init:],
  y_model[n_init:])`` in the official units, beside the published figures.
"""

import base64
import html
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from skhybrid.experiments._measured_zoo import (
    MeasuredContext,
    _rmse,
    _tail_split,
    fit_model,
    zoo,
)
from skhybrid.experiments._sealed import SELECTION_FILE
from skhybrid.experiments._spec import SystemSpec

__all__ = [
    "DEFAULT_SEEDS",
    "MeasuredResult",
    "MeasuredSettings",
    "MeasuredSystem",
    "check_seeds",
    "load_fitted",
    "measured_identity",
    "run_measured",
    "run_system",
]

#: Most residual evaluations of a physics' fit in a quick run.
QUICK_NFEV = 20


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
    """A measured system in the pipeline: its :class:`SystemSpec`, the runner's hooks.

    The runner calls :meth:`default_settings`, :meth:`new_result`,
    :meth:`model_zoo` and :meth:`job`; the zoo reads the physics and the
    candidates through the system. A user's system wraps a spec
    (:meth:`from_spec`); a built-in benchmark builds its spec from its files
    (:meth:`make_spec`).

    Parameters
    ----------
    spec : SystemSpec or None, default=None
        The system; None for a built-in benchmark, whose spec is built from
        its files.
    """

    #: Runs on measured records, not on simulated splits.
    measured = True
    name = ""
    title = ""
    unit = ""
    #: Factor from the data's units to the official reporting units.
    scale = 1.0
    #: Whether the zoo holds state-space hybrids (without reading any record).
    hybrids = True

    def __init__(self, spec=None):
        self._spec = spec
        if spec is not None:
            self.name = spec.name
            self.title = spec.title or spec.name
            self.unit = spec.unit
            self.scale = float(spec.scale)
            self.hybrids = spec.has_hybrids()

    @classmethod
    def from_spec(cls, spec):
        """The system of a user's spec.

        Parameters
        ----------
        spec : SystemSpec
            The system.

        Returns
        -------
        system : MeasuredSystem
            Bound to ``spec``.
        """
        if not isinstance(spec, SystemSpec):
            raise TypeError(f"spec must be a SystemSpec; got {type(spec).__name__}.")
        _check_picklable(spec)
        return cls(spec)

    def make_spec(self, data=None, quick=False):
        """The system's spec (a built-in benchmark builds it from its files).

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            A built-in benchmark's quick form (a shorter Silverbox record).

        Returns
        -------
        spec : SystemSpec
            The system.
        """
        if self._spec is None:
            raise NotImplementedError("a built-in benchmark builds its own spec")
        return self._spec

    @property
    def spec(self):
        """The spec the system is bound to (after :meth:`new_result`)."""
        if self._spec is None:
            raise AttributeError(f"{self.name}: no spec bound yet (call new_result)")
        return self._spec

    def bind(self, data=None, quick=False):
        """A copy of the system bound to its spec.

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            A built-in benchmark's quick form.

        Returns
        -------
        system : MeasuredSystem
            With :attr:`spec` set.
        """
        if self._spec is not None:
            return self
        return type(self)(self.make_spec(data, quick))

    def check_files(self, data=None, quick=False):
        """Load and check the estimation records (a bad file raises here).

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            The quick form.
        """
        self.bind(data, quick).spec.estimation_records()

    # -- what the zoo reads --------------------------------------------------------
    @property
    def physics_inputs(self):
        return self.spec.physics_inputs

    @property
    def hybrid_records(self):
        return self.spec.hybrid_records

    def physics(self, U, Y, dt, quick=False):
        """An unfitted physics for the records (its fit shortened when quick)."""
        model = self.spec.make_physics(U, Y, dt)
        if quick and "max_nfev" in model.get_params(deep=False):
            limit = model.get_params(deep=False)["max_nfev"]
            model.set_params(
                max_nfev=QUICK_NFEV if limit is None else min(limit, QUICK_NFEV)
            )
        return model

    def segment_candidates(self, ctx):
        """The physics' segment lengths to try on the fitting parts of ``ctx``."""
        segments = self.spec.segment_candidates(_fit_lengths(ctx))
        return segments[:1] if ctx.quick else segments

    def has_hybrids(self, quick=False):
        """Whether the zoo holds state-space hybrids."""
        return bool(self.hybrids)

    def hybrid_candidates(self, ctx):
        """The state-space hybrids to try, by label (quick: the first, shortened)."""
        candidates = self.spec.hybrid_candidates(_fit_lengths(ctx))
        if ctx.quick and candidates:
            label, settings = next(iter(candidates.items()))
            quick = dict(settings, max_epochs=min(settings.get("max_epochs", 6), 6))
            quick["hidden_layer_sizes"] = (16, 16)
            return {label: quick}
        return candidates

    def published(self):
        """The published test figures, ``{split: {label: (rmse, source)}}``."""
        if self._spec is not None and self._spec.published:
            return self._spec.published
        from skhybrid.experiments._benchmarks import PUBLISHED

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

    def store_key(self, settings):
        """The run folder's name for this system's models at ``settings``' seed."""
        return f"{self.name}-seed-{settings.seed}"

    def new_result(self, settings, data):
        """Load the estimation records and return an empty :class:`MeasuredResult`.

        No test record is read: they are read once the selection is sealed.

        Parameters
        ----------
        settings : MeasuredSettings
            ``quick`` and ``seed``.
        data : str or Path or None
            A built-in benchmark's data folder; None fetches its files.

        Returns
        -------
        result : MeasuredResult
            The bound system, the records, ``n_init`` and ``dt``; no model yet.
        """
        system = self.bind(data, settings.quick)
        U, Y = system.spec.estimation_records()
        return MeasuredResult(
            system, settings, (U, Y), system.spec.n_init, system.spec.sample_period()
        )

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
        """The joblib call that chooses and refits one model.

        Parameters
        ----------
        name : str
            The model's name.
        model : ZooModel
            Its candidates and fit.
        result : MeasuredResult
            The records and settings (its system is bound to the spec).
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

        U, Y = result.train
        ctx = MeasuredContext(
            result.system,
            U,
            Y,
            int(result.n_init),
            float(result.dt),
            result.settings.quick,
            result.settings.seed,
        )
        return delayed(fit_model)(name, model, ctx, deps, sink)


def _fit_lengths(ctx):
    """Lengths of the records' fitting parts (before their validation tails)."""
    (U_fit, _), _ = _tail_split(ctx.U, ctx.Y)
    return [len(u) for u in U_fit]


class MeasuredResult:
    """One seed's run of one measured system: the selection, then its test scores.

    Parameters
    ----------
    system : MeasuredSystem
        The system, bound to its spec.
    settings : MeasuredSettings
        ``quick`` and ``seed``.
    train : tuple of list of ndarray
        The estimation records ``(U, Y)``.
    n_init : int
        Samples of the initialisation window.
    dt : float
        Sample period.

    Attributes
    ----------
    tests : dict of str to tuple of ndarray
        ``{split: (u, y)}``: the test records, empty until the selection is
        sealed (:func:`~skhybrid.experiments._sealed.score_tests`).
    predictions : dict of str to dict of str to ndarray
        ``predictions[split][model]``: the free run over each test record (NaN
        where it failed), in the data's units.
    rows : list of dict
        One row per model and test record (``results.csv``).
    params : dict of str to dict
        Fitted physical parameters and standard errors.
    fits : dict of str to dict
        Fit time, epochs, warnings, validation RMSE and the choices of each
        model.
    estimators : dict of str to object
        The fitted models (loaded from the run folder where resumed).
    hull : dict
        On the Silverbox arrow: the first test sample whose window leaves the
        training hull, and how many do.
    wall_time : float
        Seconds for the selection.
    """

    def __init__(self, system, settings, train, n_init, dt):
        self.system = system
        self.settings = settings
        self.train = train
        self.tests = {}
        self.n_init = int(n_init)
        self.dt = float(dt)
        self.predictions = {}
        self.rows = []
        self.params = {}
        self.fits = {}
        self.estimators = {}
        self.hull = {}
        #: First scored sample of each test record (default: ``n_init``).
        self.score_start = {}
        self.wall_time = float("nan")

    @property
    def store_key(self):
        return self.system.store_key(self.settings)

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
        start = self.score_start.get(split, self.n_init)
        return self.system.scale * _rmse(y, self.predictions[split][model], start)

    def validation_rmse(self):
        """``{model: validation-tail RMSE}`` (official units) of the quoted models."""
        return {
            model: fit["validation_rmse"]
            for model, fit in self.fits.items()
            if fit.get("validation_rmse") is not None
            and np.isfinite(fit["validation_rmse"])
        }

    def selected_model(self):
        """The model to quote: the lowest free-run RMSE on the validation tails."""
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
            One row (one output).
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
                "chosen": model == self.selected_model(),
                "fit_time_s": fit.get("fit_time"),
                "n_epochs": fit.get("n_epochs"),
            }
        ]

    def selection(self):
        """What was chosen at this seed, before any test record was read.

        Returns
        -------
        selection : dict
            The settings, each model's candidates with their validation RMSE
            and choice, the validation RMSE of each model, the chosen model and
            the physics' fitted parameters.
        """
        physics = self.params.get("physics", {})
        return {
            "seed": self.settings.seed,
            "settings": self.settings.to_dict(),
            "models": {
                model: _jsonable(fit.get("selection"))
                for model, fit in self.fits.items()
            },
            "validation_rmse": self.validation_rmse(),
            "chosen_model": self.selected_model(),
            "physics_params": {k: p["value"] for k, p in physics.items()},
        }


def _jsonable(value):
    """``value`` with floats that JSON writes the same way every time."""
    import json

    return json.loads(json.dumps(value, default=str))


def _hull_exit(train, test, n_init):
    """First test index whose ``[y(t), y(t-1), u(t)]`` leaves the training hull."""
    from skhybrid.model_selection import in_convex_hull

    def rows(u, y):
        y = np.ravel(y)
        return np.column_stack([y[1:], y[:-1], np.asarray(u)[1:, 0]])

    U, Y = train
    inside = in_convex_hull(
        rows(*test), np.vstack([rows(u, y) for u, y in zip(U, Y, strict=True)])
    )
    outside = np.flatnonzero(~inside) + 1
    return (int(outside[0]) if outside.size else None), int(outside.size)


def measured_figure(run, out_dir):
    """Draw the test records and each model's free run (first seed); return the path.

    Parameters
    ----------
    run : MeasuredRun
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

    result = run.results[0]
    system, tests, n_init, dt = result.system, result.tests, result.n_init, result.dt
    fig = Figure(figsize=(7 * max(1, len(tests)), 6))
    axes = fig.subplots(2, max(1, len(tests)), sharex="col", squeeze=False)
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
        top.set_title(f"{system.title}: {split} (seed {result.settings.seed})")
        unit = system.unit
        top.set_ylabel(f"output [{unit}]")
        bottom.set_ylabel(f"simulation error [{unit}]\n(physics-based models)")
        bottom.set_xlabel("time [s] (grey: init window; red: leaves the training hull)")
        top.legend(fontsize=7)
    fig.tight_layout()
    path = Path(out_dir) / f"{_slug(system.name)}.png"
    fig.savefig(path, dpi=90)
    return path


def _slug(text):
    from skhybrid.experiments._store import _slug as slug

    return slug(text)


def _figure_text(spread):
    if spread["mean"] is None:
        return "failed"
    text = f"{spread['mean']:.4g} &plusmn; {spread['std']:.2g}"
    if spread.get("n_failed"):
        text += f" ({spread['n_failed']} failed)"
    return text


def measured_section(run, figure):
    """The report's HTML section of a measured run.

    Parameters
    ----------
    run : MeasuredRun
        A finished run.
    figure : Path
        Its figure, embedded in the page.

    Returns
    -------
    section : str
        HTML.
    """
    summary = run.summary()
    unit = html.escape(summary["unit"])
    seeds = ", ".join(str(s) for s in summary["seeds"])
    rows = []
    for split, scores in summary["test_rmse"].items():
        chosen = summary["chosen_test_rmse"][split]
        rows.append(
            f"<tr><td>{html.escape(split)}</td><td><b>chosen on validation</b></td>"
            f"<td><b>{_figure_text(chosen)}</b></td><td></td><td>ours</td></tr>"
        )
        for model, spread in scores.items():
            validation = [
                v[model] for v in summary["validation_rmse"].values() if model in v
            ]
            val = f"{np.mean(validation):.4g}" if validation else ""
            rows.append(
                f"<tr><td>{html.escape(split)}</td><td>{html.escape(model)}</td>"
                f"<td>{_figure_text(spread)}</td><td>{val}</td><td>ours</td></tr>"
            )
        for label, entry in summary["published"].get(split, {}).items():
            rows.append(
                f"<tr><td>{html.escape(split)}</td><td>{html.escape(label)}</td>"
                f"<td>{entry['rmse']:.4g}</td><td></td>"
                f"<td>{html.escape(entry['source'])}</td></tr>"
            )
    params = "; ".join(
        f"seed {seed}: "
        + ", ".join(
            f"{html.escape(k)} = {float(v):.5g}"
            for k, v in values.items()
            if np.ndim(v) == 0
        )
        for seed, values in summary["physics_params"].items()
    )
    data = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
    chosen = ", ".join(
        f"seed {s}: {html.escape(str(m))}" for s, m in summary["chosen_model"].items()
    )
    notes = (
        f"<p>Candidates: {html.escape(summary['notes'])}</p>"
        if summary["notes"]
        else ""
    )
    return f"""<h2>{html.escape(summary["title"])}</h2>
<p>Free-run simulation RMSE on the test record(s) [{unit}], mean &plusmn; standard
deviation over seeds {seeds} (each seed a full selection); the first
{summary["n_init"]} measured samples initialise the state. Every model was fitted
on the estimation records only; every choice (window and segment lengths, the
hybrid's horizon T, the model quoted) was made on the last 25 % of each record,
with the candidates fitted on the first 75 %.
quick = {summary["quick"]}, {summary["wall_time_s"]:.0f} s.</p>
<p>Sealed selection: <code>{SELECTION_FILE}</code>, SHA-256
<code>{summary["selection_sha256"]}</code>, written before any test record was
read.</p>{notes}
<table><tr><th>test</th><th>model</th><th>RMSE [{unit}]</th>
<th>validation RMSE [{unit}] (mean)</th><th>source</th></tr>
{"".join(rows)}</table>
<p>Chosen on the validation tails (never on a test record): {chosen}.</p>
<p>Physics parameters: {params}</p>
<h4>Test records and free runs (seed {summary["seeds"][0]})</h4>
<img alt='{html.escape(summary["title"])}' src='data:image/png;base64,{data}'>
"""


#: The seeds of a measured run: each a full selection.
DEFAULT_SEEDS = (0, 1, 2)


def check_seeds(seeds):
    """The seeds of a measured run, checked: distinct ints >= 0.

    Parameters
    ----------
    seeds : sequence of int
        Each seed is a full selection.

    Returns
    -------
    seeds : list of int
        The seeds.

    Raises
    ------
    ValueError
        An empty sequence, a seed that is not an int >= 0, or a repeated seed.
    """
    seeds = list(seeds)
    if not seeds or any(
        isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 0
        for s in seeds
    ):
        raise ValueError(
            f"seeds must be a non-empty sequence of ints >= 0; got seeds={seeds!r}."
        )
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must differ; got seeds={seeds!r}.")
    return [int(s) for s in seeds]


def measured_identity(system, quick, seeds):
    """What makes two measured runs the same (a resumed run must match it).

    Parameters
    ----------
    system : MeasuredSystem
        The system.
    quick : bool
        Shorter fits.
    seeds : list of int
        The seeds.

    Returns
    -------
    identity : dict
        The version, the system, ``quick``, the seeds and the settings.
    """
    import skhybrid

    settings = system.default_settings(quick, seeds[0])
    return {
        "skhybrid": skhybrid.__version__,
        "systems": [system.name],
        "quick": bool(quick),
        "seeds": list(seeds),
        "settings": settings.to_dict(),
    }


def _run_folder(
    system, command, out, *, data, quick, seeds, n_jobs, overwrite, resume, progress
):
    from skhybrid.experiments._report import write_report
    from skhybrid.experiments._sealed import run_seeds
    from skhybrid.experiments._store import RunFolder

    identity = measured_identity(system, quick, seeds)
    folder = RunFolder(out).prepare()
    try:
        folder.start(
            identity,
            command,
            overwrite=overwrite,
            resume=resume,
        )
        run = run_seeds(
            system,
            seeds=seeds,
            quick=quick,
            n_jobs=n_jobs,
            progress=progress,
            folder=folder,
            data=data,
        )
        write_report([run], folder.path)
        folder.complete()
    finally:
        folder.lock.release()
    return run.summary()


def _check_picklable(spec):
    """Refuse, before any fit, a physics the run folder cannot store."""
    import pickle

    for name in ("physics", "physics_inputs"):
        try:
            pickle.dumps(getattr(spec, name))
        except (pickle.PicklingError, AttributeError, TypeError) as exc:
            raise TypeError(
                f"spec.{name} cannot be pickled ({exc}), so its fitted models "
                "cannot be kept in the run folder: define its functions at module "
                "level in a file (not in a notebook cell, a lambda or a closure)."
            ) from None


def run_system(
    spec,
    out,
    *,
    seeds=DEFAULT_SEEDS,
    quick=False,
    n_jobs=1,
    overwrite=False,
    resume=False,
    progress=False,
):
    """Fit, choose, seal and score a measured system described by ``spec``.

    The public workflow of a user's machine (and of the built-in benchmarks):
    at each seed the default candidate family is fitted on the estimation
    records and every choice made on their validation tails; the selections of
    all seeds are written to ``OUT/selection.json`` with their SHA-256 before
    any test record is read; then every model is simulated on the test records
    and ``results.csv``, ``results.json`` (the hash, each seed's choice and the
    chosen model's test RMSE over seeds), ``report.html`` and a figure are
    written. The same as ``skhybrid run --system module:object --out OUT``.

    Parameters
    ----------
    spec : SystemSpec
        The system.
    out : str or Path
        The run folder, checked and locked before any fit; finished models are
        kept as they land and an unfinished run of the same settings is carried
        on.
    seeds : sequence of int, default=(0, 1, 2)
        Seeds of the networks; each is a full selection.
    quick : bool, default=False
        Shorter fits and fewer candidates (a smoke test, not a figure).
    n_jobs : int, default=1
        Models fitted in parallel with joblib.
    overwrite : bool, default=False
        Replace a previous run in ``out``.
    resume : bool, default=False
        Also accept a finished run of the same settings (its report is written
        again).
    progress : bool, default=False
        Progress bars on standard error.

    Returns
    -------
    results : dict
        The system's entry of ``results.json``.

    Examples
    --------
    >>> from skhybrid.experiments import SystemSpec, run_system  # doctest: +SKIP
    >>> spec = SystemSpec("my-machine", records=[(u1, y1), (u2, y2)],
    ...                   physics=physics, n_init=10, dt=0.01,
    ...                   tests={"test": (u3, y3)})  # doctest: +SKIP
    >>> results = run_system(spec, "runs/my-machine")  # doctest: +SKIP
    >>> results["chosen_test_rmse"]["test"]["mean"]  # doctest: +SKIP
    """
    system = MeasuredSystem.from_spec(spec)
    seeds = check_seeds(seeds)
    command = (
        f"skhybrid.experiments.run_system(<SystemSpec {spec.name!r}>, "
        f"{str(out)!r}, seeds={seeds}, quick={bool(quick)})"
    )
    return _run_folder(
        system,
        command,
        out,
        data=None,
        quick=quick,
        seeds=seeds,
        n_jobs=n_jobs,
        overwrite=overwrite,
        resume=resume,
        progress=progress,
    )


def run_measured(
    name, data, out, *, quick=False, seeds=DEFAULT_SEEDS, n_jobs=1, overwrite=False
):
    """Run a built-in measured benchmark into the run folder ``out``.

    The same pipeline as ``skhybrid run NAME --data DATA --out OUT``: the folder
    is checked and locked before any fit, finished models are kept as they land,
    an unfinished run of the same settings in ``out`` is carried on, and the
    selection of every seed is sealed before the test records are read.

    Parameters
    ----------
    name : str
        A built-in measured benchmark (``skhybrid list``).
    data : str or pathlib.Path or None
        Folder holding the benchmark files (for example ``../shared/data``);
        None fetches them.
    out : str or pathlib.Path
        The run folder: ``selection.json``, ``results.csv``, ``results.json``,
        ``report.html``, ``<name>.png`` and ``models/``.
    quick : bool, default=False
        Shorter fits (and a shorter Silverbox estimation record).
    seeds : sequence of int, default=(0, 1, 2)
        Seeds of the networks; each is a full selection.
    n_jobs : int, default=1
        Models fitted in parallel with joblib.
    overwrite : bool, default=False
        Replace a previous run in ``out``.

    Returns
    -------
    results : dict
        The system's entry of ``results.json``.
    """
    from skhybrid.experiments._benchmarks import MEASURED_SYSTEMS

    if name not in MEASURED_SYSTEMS:
        raise ValueError(
            f"name must be one of {sorted(MEASURED_SYSTEMS)}; got name={name!r}."
        )
    import shlex

    seeds = check_seeds(seeds)
    words = ["run", name] + (["--data", str(data)] if data is not None else [])
    words += ["--out", str(out)] + ["--quick"] * bool(quick)
    words += ["--seeds", *map(str, seeds)]
    return _run_folder(
        MEASURED_SYSTEMS[name],
        "skhybrid " + shlex.join(words),
        out,
        data=data,
        quick=quick,
        seeds=seeds,
        n_jobs=n_jobs,
        overwrite=overwrite,
        resume=False,
        progress=False,
    )


def load_fitted(out, *, seed=0, model=None, system=None):
    """A fitted model of a finished measured run: the chosen one by default.

    Parameters
    ----------
    out : str or Path
        The run folder (of :func:`run_system`, :func:`run_measured` or ``skhybrid
        run``).
    seed : int, default=0
        Which seed's fit.
    model : str or None, default=None
        The model's name in the report (``"physics"``, ``"physics + dense"``...);
        None loads the model chosen on validation at ``seed``.
    system : str or None, default=None
        The system's name; None where the folder holds one system.

    Returns
    -------
    estimator : object
        The fitted model; its ``simulate(inputs, initial)`` runs free from a
        record's first ``n_init`` measured outputs, as the run scored it.

    Examples
    --------
    >>> from skhybrid.experiments import load_fitted  # doctest: +SKIP
    >>> chosen = load_fitted("runs/my-machine", seed=0)  # doctest: +SKIP
    >>> y_sim = chosen.simulate(u_test, y_test[:10])  # doctest: +SKIP
    """
    import json

    from skhybrid.experiments._store import RunFolder

    folder = RunFolder(out)
    try:
        systems = json.loads((folder.path / "results.json").read_text())["systems"]
    except FileNotFoundError:
        raise FileNotFoundError(
            f"{folder.path} holds no finished run (no results.json)"
        ) from None
    if system is None:
        if len(systems) != 1:
            raise ValueError(
                f"{folder.path} holds the systems {sorted(systems)}: name one with "
                "system=..."
            )
        system = next(iter(systems))
    if system not in systems or "chosen_model" not in systems[system]:
        raise ValueError(
            f"system must be a measured system of {folder.path}; got "
            f"system={system!r} (it holds {sorted(systems)})."
        )
    summary = systems[system]
    if str(seed) not in summary["chosen_model"]:
        raise ValueError(
            f"seed must be one of the run's seeds {summary['seeds']}; got "
            f"seed={seed!r}."
        )
    if model is None:
        model = summary["chosen_model"][str(seed)]
    key = f"{system}-seed-{seed}"
    finished = folder.finished(key)
    if model not in finished:
        raise ValueError(
            f"model must be one of {sorted(finished)}; got model={model!r}."
        )
    return folder.load_estimator(key, finished[model])
