"""The sealed test: every seed's selection is frozen and hashed before any test record.

A measured run searches the candidate family at its first seed and refits each
choice at every seed (:func:`run_seeds`), then writes
``selection.json``: the spec's description, every candidate's validation RMSE,
every choice and the chosen model of each seed, with the SHA-256 of all of it.
Only then are the test records read (:meth:`SystemSpec.test_records`) and every
fitted model simulated on them (:func:`score_tests`). The report prints the hash
beside the test figures, so a reader can check that the figures come from the
selection the file records, made before the test was seen.
"""

import hashlib
import json
import time

import numpy as np

from skhybrid.exceptions import RefusedTestRecordsError
from skhybrid.experiments._describe import canonical, spec_fields
from skhybrid.experiments._measured_report import (
    hull_exit,
    measured_figure,
    measured_section,
)
from skhybrid.experiments._measured_stack import STACK, averaged_run
from skhybrid.experiments._measured_zoo import simulate_records
from skhybrid.experiments._provenance import provenance
from skhybrid.experiments._runner import fit_seed, fit_zoos
from skhybrid.experiments._settings import RunSettings
from skhybrid.experiments._spec import records_digest
from skhybrid.experiments._stochastic import (
    BAND_LEVEL,
    band_coverage,
    fit_noise,
    residual_tests,
)
from skhybrid.experiments._store import SELECTION_FILE, _write_atomic
from skhybrid.experiments._test_runs import simulate_tests
from skhybrid.model_selection import StackedSimulation

__all__ = [
    "MeasuredRun",
    "describe_spec",
    "record_digests",
    "run_seeds",
    "score_tests",
    "seal",
]


def describe_spec(spec, U, Y=None):
    """What of a spec the selection depends on, as JSON-ready data.

    Parameters
    ----------
    spec : SystemSpec
        The system.
    U : list of ndarray
        Its estimation records' inputs (their lengths are recorded).
    Y : list of ndarray or None, default=None
        Their outputs; with them, the records' SHA-256 is recorded too.

    Returns
    -------
    description : dict
        Name, sample period, ``n_init``, record lengths, the physics, the
        candidate family and the notes.
    """
    return {
        **spec_fields(spec),
        "dt": spec.sample_period(),
        "record_lengths": [len(u) for u in U],
        "records_sha256": None if Y is None else records_digest(U, Y),
    }


def seal(results, folder_path):
    """Write the frozen selection of every seed and its hash; return both.

    Parameters
    ----------
    results : list of MeasuredResult
        One per seed, every model fitted and chosen; no test record read.
    folder_path : Path or None
        The run folder (``selection.json`` goes there); None writes nothing.

    Returns
    -------
    sealed : dict
        ``sha256`` and ``selection`` (what was hashed).
    """
    system = results[0].system
    selection = {
        "system": describe_spec(system.spec, *results[0].train),
        "seeds": [r.selection() for r in results],
        # The code and CPU kernels the selection was made with.
        "provenance": provenance(),
    }
    digest = hashlib.sha256(canonical(selection).encode()).hexdigest()
    sealed = {"sha256": digest, "selection": selection}
    if folder_path is not None:
        text = json.dumps(
            {"sha256": digest, "hashed": "canonical JSON of 'selection'", **sealed},
            indent=1,
            default=str,
        )
        _write_atomic(folder_path / SELECTION_FILE, lambda p: p.write_text(text))
    return sealed


def score_tests(result, tests, folder=None, runs=None):
    """Score every fitted model of one seed on the test records.

    Parameters
    ----------
    result : MeasuredResult
        A sealed seed's result (``estimators`` fitted).
    tests : dict of str to tuple of ndarray
        ``{split: (u, y)}``, read after sealing.
    folder : RunFolder or None, default=None
        Where the free runs are kept (``models/<system>-seed-<S>/
        test-predictions.npz``, keys ``<test>/<model>``).
    runs : dict or None, default=None
        The models' free runs of the test records, as
        :func:`~skhybrid.experiments._test_runs.simulate_tests` gives them for
        this seed; None simulates them here.
    """
    result.tests = dict(tests)
    result.predictions = {split: {} for split in tests}
    for split, (u, y) in tests.items():
        errors = {}
        given = {} if runs is None else runs[split]
        for model in result.fits:
            estimator = result.estimators.get(model)
            if estimator is None:
                pred = np.full(len(y), np.nan)
            else:
                pred = None
                if isinstance(estimator, StackedSimulation):
                    # Its members ran already: their runs averaged, not rerun.
                    pred, error = averaged_run(
                        estimator, result.predictions[split], errors
                    )
                elif model in given:
                    pred, error = given[model]
                if pred is None:
                    (pred,), (error,) = simulate_records(
                        estimator, [u], [y], result.n_init
                    )
                errors[model] = error
                if error is not None:
                    result.fits[model].setdefault("selection", {})
                    result.fits[model]["selection"]["diverged_on_" + split] = error
            result.predictions[split][model] = pred
    if result.system.spec.score_from_estimation_start:
        U_est, Y_est = result.train
        for split, (u, y) in tests.items():
            name = f"{split}{ORIGINAL_PROTOCOL}"
            result.tests[name] = (u, y)
            result.score_start[name] = 0
            result.predictions[name] = {
                model: _from_estimation_start(
                    result.estimators.get(model), u, U_est[0], Y_est[0], result.n_init
                )
                for model in result.fits
            }
    if "test_arrow_full" in tests:
        first, count = hull_exit(result.train, tests["test_arrow_full"], result.n_init)
        result.hull = {"test_arrow_full": {"first_outside": first, "n_outside": count}}
    if folder is not None:
        folder.save_arrays(
            result.store_key,
            "test-predictions",
            {
                f"{split}/{model}": pred
                for split, preds in result.predictions.items()
                for model, pred in preds.items()
            },
        )
    result.rows = [
        row
        for split in result.predictions
        for model in result.predictions[split]
        for row in result.model_rows(split, model)
    ]
    result.stochastic = stochastic_part(result)


def _out_of_fold_residuals(result, model, joined=True):
    """A model's out-of-fold free-run residuals and the inputs at their samples.

    The held-out blocks of each fold, after their first samples, joined block
    after block as the out-of-fold runs are.

    Returns
    -------
    residuals : ndarray or list of ndarray
        Joined, or one array per fold (``joined=False``).
    inputs : ndarray of shape (n_samples, n_inputs)
        The inputs at the same samples.

    None where the model has no out-of-fold runs.
    """
    runs = result.validation_runs.get(model)
    if runs is None or model not in result.fits:
        return None
    start = int(result.fits[model].get("selection", {}).get("validation_start", 0))
    residuals, inputs = [], []
    for (U_b, Y_b), run in zip(result.validation_blocks(), runs, strict=True):
        measured = np.concatenate([np.ravel(y)[start:] for y in Y_b])
        residuals.append(measured - np.ravel(run))
        inputs.append(np.vstack([np.asarray(u)[start:] for u in U_b]))
    inputs = np.vstack(inputs)
    return (np.concatenate(residuals) if joined else residuals), inputs


def stochastic_part(result):
    """The chosen model's residual tests, noise model and band coverage.

    The noise model is fitted on the chosen model's out-of-fold free-run
    residuals over the held-out blocks of the estimation records (never on a
    test record); its band is then laid on each test record's free run.

    Parameters
    ----------
    result : MeasuredResult
        A seed's result, scored on its test records.

    Returns
    -------
    stochastic : dict
        ``model``, ``level``, ``validation`` (residual tests), ``noise`` (the
        noise model's description), ``tests`` (``{split: residual tests and
        coverage}``) and ``physics_validation`` (the same tests of the
        physics' own out-of-fold residuals, or None); ``{"model": None}``
        where no model was chosen, and
        ``noise.fitted`` False with the reason where no noise model could be
        fitted.
    """
    model = result.selected_model()
    # The physics' own residuals: its standard errors assume its structure,
    # which white residuals support and coloured ones contradict.
    physics = _out_of_fold_residuals(result, "physics")
    physics = None if physics is None else residual_tests(*physics)
    if model is None or result.validation_runs.get(model) is None:
        return {
            "model": model,
            "level": BAND_LEVEL,
            "noise": {"fitted": False},
            "physics_validation": physics,
        }
    residuals, inputs = _out_of_fold_residuals(result, model, joined=False)
    scale = result.system.scale
    noise, description = fit_noise(residuals)
    out = {
        "model": model,
        "level": BAND_LEVEL,
        "physics_validation": physics,
        "validation": residual_tests(np.concatenate(residuals), inputs),
        "noise": {
            k: scale * v if k in ("innovation_std", "mean", "std") else v
            for k, v in description.items()
        },
        "tests": {},
    }
    result.bands = {}
    for split, (u, y) in result.tests.items():
        pred = result.predictions[split].get(model)
        begin = result.score_start.get(split, result.n_init)
        if pred is None:
            continue
        tests = residual_tests(
            np.ravel(y)[begin:] - np.ravel(pred)[begin:], np.asarray(u)[begin:]
        )
        tests["coverage"] = None
        if noise is not None:
            lower, upper, tests["coverage"] = band_coverage(y, pred, begin, noise)
            result.bands[split] = (lower, upper)
        out["tests"][split] = tests
    return out


#: Suffix of a test record scored from the estimation record's initial state.
ORIGINAL_PROTOCOL = "_original_protocol"


def _from_estimation_start(model, u, u_est, y_est, n_init):
    """Free run of ``u`` from the state estimated on the estimation record's window.

    Defined for a :class:`~skhybrid.domain.StateSpaceModel` physics (behind
    transformed inputs), its static corrections and the state-space hybrid
    (its corrected run from the physics' state), and for a stack of them (its
    weighted average of their runs); NaN for other models.
    """
    nan = np.full(len(u), np.nan)
    if isinstance(model, StackedSimulation):
        runs = [
            w * _from_estimation_start(member, u, u_est, y_est, n_init)
            for w, member in zip(model.weights_, model.estimators_, strict=True)
            if w > 0
        ]
        return np.sum(runs, axis=0) if runs else nan
    correction = model if hasattr(model, "correct") else None
    physics = getattr(model, "physics", None) if correction is not None else model
    inner = getattr(physics, "estimator", physics)
    if not hasattr(inner, "simulate_from_state"):
        return nan
    feed = physics.inputs if hasattr(physics, "inputs") else (lambda a: a)
    try:
        x0 = inner.estimate_initial_state(feed(u_est[:n_init]), y_est[:n_init])
        y_phys = np.ravel(inner.simulate_from_state(feed(u), x0))
        if correction is not None:
            y_phys = correction.correct(u, y_phys)
    except (ValueError, FloatingPointError, ArithmeticError):
        return nan
    return np.ravel(y_phys).astype(float)


def _spread(values):
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return {
            "mean": None,
            "std": None,
            "min": None,
            "max": None,
            "by_seed": values.tolist(),
        }
    std = float(finite.std(ddof=1)) if finite.size > 1 else 0.0
    if np.ptp(finite) <= 1e-12 * np.abs(finite).max():
        std = 0.0  # the same figure at every seed, up to rounding of its mean
    return {
        "mean": float(finite.mean()),
        "std": std,
        "min": float(finite.min()),
        "max": float(finite.max()),
        "n_failed": int(values.size - finite.size),
        "by_seed": [None if not np.isfinite(v) else float(v) for v in values],
    }


def _cv_rmse(result):
    """Each model's CV RMSE at one seed: its chosen candidate's mean, std, folds."""
    out = {}
    for name, fit in result.fits.items():
        selection = fit.get("selection") or {}
        if "cv_rmse_chosen_by_fold" not in selection:
            continue
        out[name] = {
            "mean": fit["validation_rmse"],
            "std": selection["cv_rmse_std"],
            "by_fold": selection["cv_rmse_chosen_by_fold"],
            "folds": selection["cv_folds"],
        }
    return out


class MeasuredRun:
    """A measured system's run over its seeds: selections, seal and test scores.

    Parameters
    ----------
    results : list of MeasuredResult
        One per seed, scored on the test records.
    sealed : dict
        :func:`seal`'s ``sha256`` and ``selection``.

    Attributes
    ----------
    system : MeasuredSystem
        The system.
    settings : RunSettings
        The first seed's settings (``quick``).
    seeds : list of int
        The seeds (the first searched, each refitted).
    rows : list of dict
        ``results.csv`` rows of every seed.
    wall_time : float
        Seconds for the whole run.
    """

    def __init__(self, results, sealed):
        self.results = list(results)
        self.sealed = sealed
        self.system = self.results[0].system
        self.settings = self.results[0].settings
        self.seeds = [r.settings.seed for r in self.results]
        self.rows = [row for r in self.results for row in r.rows]
        self.wall_time = float("nan")

    @property
    def sha256(self):
        return self.sealed["sha256"]

    @property
    def test_splits(self):
        return self.results[0].test_splits

    def chosen(self):
        """``{seed: model}`` chosen on validation at each seed."""
        return {r.settings.seed: r.selected_model() for r in self.results}

    def selected_model(self):
        """The models chosen at the seeds, as one line."""
        chosen = self.chosen()
        names = sorted(set(chosen.values()), key=str)
        if len(names) == 1:
            return f"{names[0]} (at every seed)"
        return ", ".join(f"seed {s}: {m}" for s, m in chosen.items())

    def test_summary(self):
        """Test RMSE over seeds: ``{split: {model: spread}}`` and the chosen model's.

        Returns
        -------
        by_model : dict
            ``{split: {model: {mean, std, min, max, n_failed, by_seed}}}``.
        chosen : dict
            ``{split: spread}`` of each seed's chosen model.
        """
        by_model, chosen = {}, {}
        for split in self.test_splits:
            models = list(dict.fromkeys(m for r in self.results for m in r.fits))
            by_model[split] = {
                m: _spread(
                    [
                        r.test_rmse(split, m) if m in r.predictions[split] else np.nan
                        for r in self.results
                    ]
                )
                for m in models
            }
            chosen[split] = _spread(
                [
                    r.test_rmse(split, r.selected_model())
                    if r.selected_model() is not None
                    else np.nan
                    for r in self.results
                ]
            )
        return by_model, chosen

    @property
    def report_title(self):
        """The report page's title: the system's own."""
        return self.system.title or self.system.name

    def report(self, out_dir):
        """Draw the figure; the report's section and ``results.json`` part.

        Parameters
        ----------
        out_dir : Path
            Where the figure goes.

        Returns
        -------
        figures : list of Path
            The figure drawn.
        section : str
            The system's HTML section.
        summary : dict
            Its part of ``results.json`` (:meth:`summary`).
        """
        path = measured_figure(self, out_dir)
        return [path], measured_section(self, path), self.summary()

    def report_settings(self):
        """The report's settings table: from the spec and the seeds.

        Returns
        -------
        settings : dict
            ``{setting: value}``.
        """
        first = self.results[0]
        return {
            "system": self.system.name,
            "seeds (searched at the first, refitted at each)": ", ".join(
                map(str, self.seeds)
            ),
            "quick": self.settings.quick,
            "n_init (samples that start each free run)": first.n_init,
            "dt [s]": first.dt,
            "estimation records (samples)": ", ".join(
                str(len(u)) for u in first.train[0]
            ),
        }

    def deterministic_models(self):
        """The models none of whose fits depends on the seed, sorted.

        Returns
        -------
        names : list of str
            Their figure is the same at every seed ("deterministic").
        """
        return sorted(
            name
            for name, fit in self.results[0].fits.items()
            if (fit.get("selection") or {}).get("deterministic")
        )

    def stack_weights(self):
        """The family's stack's weights, by model (fitted at the first seed).

        Returns
        -------
        weights : dict of str to float
            ``{model: weight}``, fitted on every fold's out-of-fold free runs;
            empty where the family has no stack or it failed.
        """
        fit = self.results[0].fits.get(STACK, {})
        return dict((fit.get("selection") or {}).get("weights") or {})

    def summary(self):
        """The system's entry of ``results.json``.

        Returns
        -------
        summary : dict
            The selection's hash, the seeds, the chosen model of each seed and
            its test RMSE over seeds (mean, spread, each seed's), every model's
            test RMSE over seeds, validation RMSE by seed, the published
            figures, the physics' parameters by seed, the chosen model's
            stochastic part by seed (residual tests, noise model, band) and
            its band's coverage of each test record over seeds, every model's
            CV RMSE by seed (mean, std and by fold), the chosen model's test /
            CV ratio over seeds, the models that cannot vary with the seed,
            the stack's weights, wall time and rows.
        """
        by_model, chosen = self.test_summary()
        first = self.results[0]
        return {
            "title": self.system.title,
            "unit": self.system.unit,
            "quick": self.settings.quick,
            "seeds": self.seeds,
            "selection_sha256": self.sha256,
            "selection_file": SELECTION_FILE,
            "n_init": first.n_init,
            "dt": first.dt,
            "n_train": [len(u) for u in first.train[0]],
            "chosen_model": {str(s): m for s, m in self.chosen().items()},
            "chosen_test_rmse": chosen,
            "test_rmse": by_model,
            "validation_rmse": {
                str(r.settings.seed): r.validation_rmse() for r in self.results
            },
            "published": {
                split: {k: {"rmse": v, "source": s} for k, (v, s) in pub.items()}
                for split, pub in self.system.published().items()
            },
            "physics_params": {
                str(r.settings.seed): {
                    k: p["value"] for k, p in r.params.get("physics", {}).items()
                }
                for r in self.results
            },
            "physics_params_std": {
                str(r.settings.seed): {
                    k: p["std"] for k, p in r.params.get("physics", {}).items()
                }
                for r in self.results
            },
            "hull": first.hull,
            "searched_at_seed": first.settings.seed,
            "cv_rmse": {str(r.settings.seed): _cv_rmse(r) for r in self.results},
            "chosen_test_over_cv": {
                split: _spread(
                    [
                        r.test_rmse(split, r.selected_model())
                        / r.validation_rmse()[r.selected_model()]
                        if r.selected_model() is not None
                        else np.nan
                        for r in self.results
                    ]
                )
                for split in self.test_splits
            },
            "deterministic": self.deterministic_models(),
            "stack_weights": self.stack_weights(),
            "stochastic": {str(r.settings.seed): r.stochastic for r in self.results},
            "band_coverage": {
                split: _spread(
                    [
                        np.nan
                        if (r.stochastic.get("tests", {}).get(split) or {}).get(
                            "coverage"
                        )
                        is None
                        else r.stochastic["tests"][split]["coverage"]
                        for r in self.results
                    ]
                )
                for split in self.test_splits
            },
            "notes": self.system.spec.notes,
            "fit_time_s": {
                str(r.settings.seed): {k: f.get("fit_time") for k, f in r.fits.items()}
                for r in self.results
            },
            "wall_time_s": self.wall_time,
            "fits": {str(r.settings.seed): r.fits for r in self.results},
            "results": self.rows,
        }


def record_digests(system, seeds, *, quick=False, data=None):
    """Read and check the estimation records; their SHA-256 under each seed's name.

    A run calls it before its folder changes: a bad record (or a test record
    given as data that does not fit them) is refused here, and a run carried on
    must find the records its finished models were fitted on
    (:meth:`~skhybrid.experiments._store.RunFolder.start`).

    Parameters
    ----------
    system : MeasuredSystem
        The system.
    seeds : list of int
        The run's seeds.
    quick : bool, default=False
        A built-in benchmark's quick form.
    data : str or Path or None, default=None
        A built-in benchmark's data folder; None fetches its files.

    Returns
    -------
    digests : dict of str to str
        ``{name of a seed's models in the folder: SHA-256 of the records}``.
    """
    bound = system.bind(data, quick)
    digest = records_digest(*bound.spec.estimation_records())
    return {bound.store_key(RunSettings(seed=seed)): digest for seed in seeds}


def first_searches(result):
    """Each model's search at ``result``'s seed, for the run's further seeds.

    Parameters
    ----------
    result : MeasuredResult
        The first seed's selection.

    Returns
    -------
    searched : dict of str to dict
        ``{model: {"selection", "runs", "seed"}}`` for every model that was
        searched.
    """
    return {
        name: {
            "selection": fit["selection"],
            "runs": result.validation_runs.get(name),
            "seed": int(result.settings.seed),
        }
        for name, fit in result.fits.items()
        if fit.get("selection")
    }


def run_seeds(
    system,
    *,
    seeds,
    quick=False,
    n_jobs=1,
    progress=False,
    folder=None,
    data=None,
    device="cpu",
):
    """Select at every seed, seal, then read and score the test records.

    Parameters
    ----------
    system : MeasuredSystem
        The system, resolved once for the run (bound by its plan).
    seeds : sequence of int
        The first seed searches; each seed refits the choices.
    quick : bool, default=False
        Shorter fits and fewer candidates.
    n_jobs : int, default=1
        Models fitted in parallel.
    progress : bool, default=False
        Progress bars on standard error.
    folder : RunFolder or None, default=None
        The run folder (finished models kept, ``selection.json`` written).
    data : str or Path or None, default=None
        A built-in benchmark's data folder; None fetches its files.

    Returns
    -------
    run : MeasuredRun
        Every seed's selection and test scores, and the seal.

    Notes
    -----
    Every model's search (each candidate on every fold) runs at the first seed,
    fold ``k``'s networks at ``seeds[0] + k``; each further seed refits the
    chosen candidate on the whole records at its own seed. The spread over
    seeds is the refits' spread; the CV figures are the one search's. The
    further seeds' refits run side by side on ``n_jobs`` workers (each with
    the threads of a search's worker, so a refit's numbers do not depend on
    what runs beside it); each of their results' ``wall_time`` is the time
    they took together.
    """
    start = time.perf_counter()
    seeds = list(seeds)
    first = fit_seed(
        system,
        RunSettings(quick=bool(quick), seed=seeds[0], device=device),
        n_jobs=n_jobs,
        progress=progress,
        folder=folder,
        data=data,
    )
    results = [first]
    if len(seeds) > 1:
        # The further seeds' refits, side by side in one pool of workers.
        refit_start = time.perf_counter()
        results += fit_zoos(
            first.system,
            [
                RunSettings(quick=bool(quick), seed=seed, device=device)
                for seed in seeds[1:]
            ],
            n_jobs=n_jobs,
            progress=progress,
            folder=folder,
            data=data,
            searched=first_searches(first),
        )
        for result in results[1:]:
            result.wall_time = time.perf_counter() - refit_start
    sealed = seal(results, None if folder is None else folder.path)
    # The first read of the test records: after the selection file is written.
    # Checked against the estimation records before any model is simulated.
    try:
        tests = results[0].system.spec.test_records(*results[0].train)
    except (TypeError, ValueError) as exc:
        where = "" if folder is None else f" in {folder.path / SELECTION_FILE}"
        raise RefusedTestRecordsError(
            f"{exc} The selection is sealed{where}: fix the test records, then "
            "run the same command with --resume (resume=True) to score it."
        ) from exc
    runs = simulate_tests(results, tests, n_jobs=n_jobs)
    for result, seed_runs in zip(results, runs, strict=True):
        score_tests(result, tests, folder, runs=seed_runs)
    run = MeasuredRun(results, sealed)
    run.wall_time = time.perf_counter() - start
    return run
