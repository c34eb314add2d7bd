"""What the run's progress says: one line per event, and the time a search has left.

The events come from the fits, through the run's sink
(:mod:`skhybrid.experiments.run._progress`), as dictionaries:

- ``{"kind": "epoch", "name", "epoch", "max_epochs", "train_loss",
  "valid_loss"}``: a network finished an epoch
  (:class:`~skhybrid.neural._callbacks.EpochProgress`);
- ``{"kind": "physics", "label", "nfev", "max_nfev", "n_records", "unit"}``: a
  physics fit evaluated its residuals
  (:func:`~skhybrid.experiments.run._progress.physics_hook`);
- ``{"kind": "search", "model", "n_candidates", "n_folds", "n_workers",
  "searched_at"}``: a model's search (or refit) begins;
- ``{"kind": "fit", "state": "start" | "done" | "failed", "model", "where",
  "fold", "candidate", "seconds"}``: one fit of a search begins or ends.

A fit's events also carry the tags of the sink that sent them (its ``seed``, and
the ``model``, ``where`` and ``candidate`` of the fit that trains a network).
"""

import math

__all__ = ["SearchClock", "count", "duration", "event_line", "fit_line"]


def count(n, noun):
    """``"1 record"``, ``"6 records"``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def duration(seconds):
    """``"0.4 s"``, ``"42 s"``, ``"3 min 20 s"``, ``"1 h 05 min"``, for a reader."""
    seconds = max(0.0, float(seconds))
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes, secs = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {secs:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


def _who(event):
    """``"state-space hybrid T=20, fold 2 of 4 (6 fit pieces), seed 0"``."""
    model = event.get("model") or event.get("name") or "model"
    candidate = event.get("candidate")
    parts = [model if not candidate else f"{model} {candidate}"]
    if event.get("where"):
        parts.append(event["where"])
    if event.get("seed") is not None:
        parts.append(f"seed {event['seed']}")
    return ", ".join(parts)


def _loss(value):
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.4g}"


def event_line(event):
    """What a fit is doing, in words, from its latest epoch or physics event.

    Parameters
    ----------
    event : dict
        An ``"epoch"``, ``"physics"`` or ``"fit"`` event.

    Returns
    -------
    text : str
        For example ``"dense NARX n=4, fold 2 of 4 (6 fit pieces), seed 0:
        epoch 12 of at most 60, valid loss 0.0123"``.
    """
    kind = event.get("kind")
    if kind == "epoch":
        if event.get("valid_loss") is not None:
            loss = f"valid loss {_loss(event['valid_loss'])}"
        else:
            loss = f"train loss {_loss(event.get('train_loss'))}"
        return (
            f"{_who(event)}: epoch {event['epoch']} of at most "
            f"{event['max_epochs']}, {loss}"
        )
    if kind == "physics":
        nfev, limit = event["nfev"], event.get("max_nfev")
        of = "" if limit is None else f" of at most {limit}"
        evaluations = "evaluation" if nfev == 1 else "evaluations"
        seed = "" if event.get("seed") is None else f", seed {event['seed']}"
        return (
            f"{event['label']}{seed}: physics fit, {nfev} residual {evaluations}"
            f"{of} ({count(event['n_records'], event.get('unit', 'record'))} "
            "simulated)"
        )
    if kind == "fit" and event.get("state") == "start":
        return f"{_who(event)}: fitting"
    if kind == "fit":
        verb = "failed after" if event.get("state") == "failed" else "fitted in"
        return f"{_who(event)}: {verb} {duration(event.get('seconds', 0.0))}"
    return str(event)


def fit_line(event, estimate=None):
    """A finished fit of a search, with the time its search has left.

    Parameters
    ----------
    event : dict
        A ``"fit"`` event of state ``"done"`` or ``"failed"``.
    estimate : float or None, default=None
        Seconds the model's search and refit have left (None: not yet known).

    Returns
    -------
    text : str
        ``"dense NARX n=4, fold 2 of 4 (6 fit pieces), seed 0: fitted in 12 s
        (3 of 12 fits); about 1 min 30 s left for this model"``.
    """
    text = event_line(event)
    if event.get("progress"):
        text += f" ({event['progress']})"
    if estimate is not None:
        text += f"; about {duration(estimate)} left for this model"
    return text


class SearchClock:
    """The time a model's search has left, from the folds it has finished.

    A search fits ``n_candidates`` candidates on ``n_folds`` folds, on
    ``n_workers`` workers, then refits the chosen one on the whole records.
    Once one fold of a candidate has finished, each of its other folds is taken
    to last as long as its finished ones on average, each fold of a candidate
    not yet seen as long as every finished fold on average, and the refit (on
    all the data instead of ``(n_folds - 1) / n_folds`` of it) as long as the
    slowest candidate's folds, scaled up by that share; the folds share the
    workers.

    Parameters
    ----------
    n_candidates : int
        Candidates searched (0: a refit only, or a model chosen otherwise).
    n_folds : int
        Folds of the search.
    n_workers : int
        Fits that run at once.
    """

    def __init__(self, n_candidates, n_folds, n_workers):
        self.n_candidates = int(n_candidates)
        self.n_folds = max(1, int(n_folds))
        self.n_workers = max(1, int(n_workers))
        self.times = {}  # candidate -> seconds of its finished folds
        self.refitted = False

    @property
    def n_fits(self):
        """Fold fits of the whole search."""
        return self.n_candidates * self.n_folds

    @property
    def n_done(self):
        """Fold fits finished."""
        return sum(len(t) for t in self.times.values())

    def record(self, event):
        """Count a finished fit (a fold's, or the refit on the whole records)."""
        if event.get("fold") is None:
            self.refitted = True
            return
        key = str(event.get("candidate"))
        self.times.setdefault(key, []).append(float(event.get("seconds", 0.0)))

    def progress(self):
        """``"3 of 12 fits"`` (empty for a search without folds)."""
        if not self.n_fits:
            return ""
        return f"{min(self.n_done, self.n_fits)} of {self.n_fits} fold fits"

    def remaining(self):
        """Seconds the search and its refit have left, or None before a fold ends.

        Returns
        -------
        seconds : float or None
            The estimate (0 once the refit has finished).
        """
        if self.refitted:
            return 0.0
        if not self.times:
            return None
        means = {k: sum(t) / len(t) for k, t in self.times.items()}
        overall = sum(sum(t) for t in self.times.values()) / self.n_done
        left = sum(max(0, self.n_folds - len(self.times[k])) * means[k] for k in means)
        unseen = max(0, self.n_candidates - len(means))
        left += unseen * self.n_folds * overall
        n_left = max(0, self.n_fits - self.n_done)
        if n_left:
            left /= min(self.n_workers, n_left)
        share = self.n_folds / (self.n_folds - 1) if self.n_folds > 1 else 1.0
        return left + max(means.values()) * share
