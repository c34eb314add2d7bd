"""Progress over models and epochs for fits that run in other processes or machines.

Each network gets an :class:`EpochLogger` callback that reports one event per
epoch to a sink that pickles into any worker:

- :class:`FileSink` appends a line to a file, for joblib's worker processes on this
  machine (the parent counts the lines);
- :class:`DaskEventSink` logs a Dask event on the worker's scheduler, for workers
  on a cluster (the client subscribes to the topic), where no file is shared.

The bar over models moves as each model's result comes back to the parent, with
any backend.

A physics fit reports its residual evaluations the same way
(:func:`physics_hook`, through :func:`skhybrid.domain.fit_progress`): the
bars show the latest fit's evaluations against its ``max_nfev`` and its
records or segments.
"""

import tempfile
import threading
import time
import uuid
from pathlib import Path

from skorch.callbacks import Callback

__all__ = [
    "DaskEventSink",
    "EpochLogger",
    "FileSink",
    "ProgressBars",
    "attach_epoch_logger",
    "epoch_budget",
    "physics_hook",
]

#: First character of a physics fit's event (an epoch's event is a model's name).
PHYSICS_EVENT = "\x1f"
#: Least time between two events of one physics fit (the first always goes).
PHYSICS_EVENT_INTERVAL = 0.5


def physics_event(label, nfev, max_nfev, n_records, unit="record"):
    """The event line of a physics fit's progress."""
    limit = "" if max_nfev is None else int(max_nfev)
    return f"{PHYSICS_EVENT}{label}\t{int(nfev)}\t{limit}\t{int(n_records)}\t{unit}"


def parse_physics_event(line):
    """``(label, nfev, max_nfev or None, n_records, unit)`` of a physics event."""
    label, nfev, limit, records, unit = line[len(PHYSICS_EVENT) :].split("\t")
    return label, int(nfev), int(limit) if limit else None, int(records), unit


def count(n, noun):
    """``"1 record"``, ``"6 records"``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def physics_hook(sink, label, unit="record"):
    """A :func:`skhybrid.domain.fit_progress` hook that reports to ``sink``.

    Parameters
    ----------
    sink : FileSink or DaskEventSink
        Where the run's progress goes.
    label : str
        What is being fitted: the model, the fold (or the refit on the whole
        records), and how its records are simulated.
    unit : str, default="record"
        What the fit's ``n_records`` counts: ``"record"``, ``"fit piece"`` (a
        fold's) or ``"segment"``.

    Returns
    -------
    hook : callable
        ``hook(nfev, max_nfev, n_records)``, emitting at most every
        ``PHYSICS_EVENT_INTERVAL`` seconds (and at a fit's first evaluation).
    """
    last = [-float("inf")]

    def hook(nfev, max_nfev, n_records):
        now = time.monotonic()
        if nfev == 1 or now - last[0] >= PHYSICS_EVENT_INTERVAL:
            last[0] = now
            sink.emit(physics_event(label, nfev, max_nfev, n_records, unit))

    return hook


class FileSink:
    """Append each event to the file ``path`` (one machine, many processes)."""

    def __init__(self, path):
        self.path = str(path)

    def emit(self, name):
        try:
            with open(self.path, "a") as f:
                f.write(f"{name}\n")
        except OSError:  # the run's progress folder is gone: progress is optional
            pass

    def poll(self):
        """``(epochs, physics)``: epochs so far, the latest physics event or None."""
        epochs, physics = 0, None
        try:
            with open(self.path) as f:
                for line in f:
                    if line.startswith(PHYSICS_EVENT):
                        physics = line.rstrip("\n")
                    else:
                        epochs += 1
        except OSError:
            pass
        return epochs, None if physics is None else parse_physics_event(physics)

    def count(self):
        return self.poll()[0]


class DaskEventSink:
    """Log each event on the Dask scheduler under ``topic`` (a cluster).

    In the client, :meth:`subscribe` counts the events of the topic; on a worker,
    :meth:`emit` logs one. Outside a Dask worker, :meth:`emit` does nothing.
    """

    def __init__(self, topic):
        self.topic = topic
        self._count = 0
        self._physics = None
        self._lock = threading.Lock()

    def __getstate__(self):
        return {"topic": self.topic}

    def __setstate__(self, state):
        self.__init__(state["topic"])

    def emit(self, name):
        try:
            from distributed import get_worker

            worker = get_worker()
        except (ImportError, ValueError):
            return
        worker.log_event(self.topic, name)

    def _on_event(self, event):
        message = event[1] if isinstance(event, tuple) else event
        with self._lock:
            if isinstance(message, str) and message.startswith(PHYSICS_EVENT):
                self._physics = parse_physics_event(message)
            else:
                self._count += 1

    def subscribe(self, client):
        client.subscribe_topic(self.topic, self._on_event)
        self._client = client
        return self

    def unsubscribe(self):
        client = getattr(self, "_client", None)
        if client is not None:
            client.unsubscribe_topic(self.topic)

    def poll(self):
        """``(epochs, physics)``: epochs so far, the latest physics event or None."""
        with self._lock:
            return self._count, self._physics

    def count(self):
        return self.poll()[0]


class EpochLogger(Callback):
    """skorch callback: report ``name`` to ``sink`` after every epoch.

    Parameters
    ----------
    sink : FileSink, DaskEventSink, str or Path
        Where events go; a path means a :class:`FileSink`.
    name : str
        The model's name.
    """

    def __init__(self, sink, name):
        self.sink = sink
        self.name = name

    def on_epoch_end(self, net, **kwargs):
        sink = self.sink
        if isinstance(sink, (str, Path)):
            sink = FileSink(sink)
        sink.emit(self.name)


def attach_epoch_logger(estimator, sink, name):
    """Add an :class:`EpochLogger` to every network inside ``estimator``."""
    keys = [
        key
        for key in estimator.get_params(deep=True)
        if key == "callbacks" or key.endswith("__callbacks")
    ]
    for key in keys:
        estimator.set_params(**{key: [EpochLogger(sink, name)]})
    return estimator


def epoch_budget(estimator):
    """The most epochs the networks inside ``estimator`` can run (0 for none).

    Each network counts ``max_epochs``, twice with ``mse_pretraining`` (the
    fine-tuning phase may run as many again); early stopping usually ends
    sooner, so this is the epoch bar's upper bound.

    Parameters
    ----------
    estimator : estimator
        A network, or a composite holding networks.

    Returns
    -------
    n_epochs : int
        The upper bound.
    """
    params = estimator.get_params(deep=True)
    total = 0
    for key, value in params.items():
        if key != "max_epochs" and not key.endswith("__max_epochs"):
            continue
        prefix = key[: -len("max_epochs")]
        if f"{prefix}callbacks" not in params:  # not a network (a least-squares fit)
            continue
        twice = (
            params.get(f"{prefix}mse_pretraining", False)
            and str(params.get(f"{prefix}objective", "mse")) != "mse"
        )
        total += int(value) * (2 if twice else 1)
    return total


class ProgressBars:
    """Progress on standard error: fitted models, and epochs of all networks.

    On a terminal, three tqdm bars: models of the run's total, epochs of the
    networks (of their largest possible total where it is known), and the
    latest physics fit's residual evaluations of its ``max_nfev``, with its
    records or segments. Elsewhere (a log file, CI), a line when the fits
    start, one per finished model, and a line on a physics fit's evaluations every
    ``log_interval`` seconds while one runs.

    Parameters
    ----------
    n_models : int
        Models in the run.
    description : str
        Prefix of both bars.
    client : distributed.Client or None, default=None
        With a Dask client, epochs are counted from Dask events; without, from a
        temporary file.
    n_done : int, default=0
        Models already finished (a resumed run).
    n_epochs : int or None, default=None
        Most epochs the run's networks can take (see :func:`epoch_budget`);
        None where it is not known before the fits.
    stream : file-like or None, default=None
        Where progress goes; None is ``sys.stderr``.
    log_interval : float, default=15.0
        Seconds between two lines on a physics fit's evaluations outside a
        terminal.
    """

    #: No rate: "?model/s" says nothing while the first model trains.
    MODELS_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}]{postfix}"

    def __init__(
        self,
        n_models,
        description,
        *,
        client=None,
        n_done=0,
        n_epochs=None,
        stream=None,
        log_interval=15.0,
    ):
        import sys

        from tqdm.auto import tqdm

        self.stream = sys.stderr if stream is None else stream
        self.description = description
        self.n_models = n_models
        self.n_done = n_done
        self.n_epochs = n_epochs
        isatty = getattr(self.stream, "isatty", None)
        self.interactive = bool(isatty and isatty())
        self._dir = None
        if client is None:
            self._dir = tempfile.TemporaryDirectory(prefix="skhybrid-progress-")
            path = Path(self._dir.name) / "epochs.log"
            path.touch()
            self.sink = FileSink(path)
        else:
            self.sink = DaskEventSink(f"skhybrid-epochs-{uuid.uuid4().hex}")
            self.sink.subscribe(client)
        self.models = self.epochs = self.physics = None
        self.log_interval = float(log_interval)
        self._physics_seen = None
        self._logged_at = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        if not self.interactive:
            # A first line at once: a log shows the run has started.
            done = f", {n_done} already finished" if n_done else ""
            models = f"{n_models} model{'s' if n_models != 1 else ''}"
            self.stream.write(f"{description}: {models} to fit{done}\n")
            self.stream.flush()
            self._thread.start()
            return
        self.models = tqdm(
            total=n_models,
            initial=n_done,
            desc=f"{description}: models",
            unit="model",
            bar_format=self.MODELS_FORMAT,
            file=self.stream,
        )
        self.epochs = tqdm(
            total=n_epochs or None,
            desc=f"{description}: epochs"
            + (" (at most, early stopping ends sooner)" if n_epochs else ""),
            unit="epoch",
            position=1,
            file=self.stream,
        )
        self.physics = tqdm(
            total=None,
            desc=f"{description}: physics evaluations",
            unit="eval",
            position=2,
            file=self.stream,
            bar_format="{desc}: {n_fmt}/{total_fmt} {postfix}",
        )
        self._thread.start()

    def _watch(self):
        while not self._stop.wait(0.5):
            self._update()

    def _update(self):
        epochs, physics = self.sink.poll()
        if self.epochs is not None:
            self.epochs.update(epochs - self.epochs.n)
        if physics is None or physics == self._physics_seen:
            return
        self._physics_seen = physics
        label, nfev, limit, records, unit = physics
        what = f"{label}; {count(records, unit)} simulated"
        if self.physics is not None:
            self.physics.total = limit
            self.physics.n = nfev
            self.physics.set_postfix_str(what, refresh=False)
            self.physics.refresh()
            return
        now = time.monotonic()
        if now - self._logged_at >= self.log_interval:
            self._logged_at = now
            of = "" if limit is None else f" of at most {limit}"
            evaluations = "evaluation" if nfev == 1 else "evaluations"
            self.stream.write(
                f"{self.description}: {label}: physics fit, {nfev} residual "
                f"{evaluations}{of} ({count(records, unit)} simulated)\n"
            )
            self.stream.flush()

    def model_done(self, name, fit_time, n_epochs, *, seed=None, searched_at=None):
        """One model finished: a line (or the models bar moves).

        Parameters
        ----------
        name : str
            The model.
        fit_time : float
            Seconds its fit (search and refit) took.
        n_epochs : int or None
            Epochs its network trained.
        seed : int or None, default=None
            The seed it was fitted at, named where a bar covers several seeds.
        searched_at : int or None, default=None
            The seed whose search chose what this fit refits, if any.
        """
        epochs = "" if n_epochs is None else f", {n_epochs} epochs"
        if seed is not None:
            name = f"{name} at seed {seed}"
        if searched_at is not None:
            name = f"{name} (refit of the choice made at seed {searched_at})"
        self.n_done += 1
        if self.models is None:
            self.stream.write(
                f"{self.description}: {self.n_done}/{self.n_models} models: "
                f"{name} ({fit_time:.1f} s{epochs})\n"
            )
            self.stream.flush()
            return
        self.models.set_postfix_str(f"{name} ({fit_time:.1f} s{epochs})")
        self.models.update()

    def close(self):
        """Stop counting and close the bars, leaving the terminal clean."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()
        if self.physics is not None:
            self.physics.close()
        if self.epochs is not None:
            self.epochs.update(self.sink.count() - self.epochs.n)
            if self.epochs.total:  # early stopping ended sooner: the bar is done
                self.epochs.total = self.epochs.n
                self.epochs.refresh()
            self.epochs.close()
            self.models.close()
            # Leave the cursor below both bars, so that what follows (an
            # interrupt's message) is not printed over them.
            self.stream.write("\n")
            self.stream.flush()
        if isinstance(self.sink, DaskEventSink):
            self.sink.unsubscribe()
        if self._dir is not None:
            self._dir.cleanup()
