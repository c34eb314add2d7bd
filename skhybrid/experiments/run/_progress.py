"""Progress of a run whose fits run in other processes or machines.

Every fit reports events (epochs, physics evaluations, the folds of a search)
to a sink that pickles into any worker:

- :class:`FileSink` appends a line to a file, for joblib's worker processes on this
  machine (the parent reads the new lines);
- :class:`DaskEventSink` logs a Dask event on the worker's scheduler, for workers
  on a cluster (the client subscribes to the topic), where no file is shared;
- :class:`Tagged` adds what a fit knows of itself (its seed, model, fold) to the
  events sent through it.

Each network gets an :class:`~skhybrid.neural._callbacks.EpochProgress`
callback (:func:`attach_epoch_logger`); a physics fit reports its residual
evaluations through :func:`physics_hook` (with
:func:`skhybrid.domain.fit_progress`); a measured model's search reports when
it begins and each fit of a fold as it ends. :class:`ProgressBars` reads them
in the run's own process: bars on a terminal, lines in a log (never 15 s
without one). What the lines say is written in
:mod:`skhybrid.experiments.run._progress_lines`.
"""

import json
import tempfile
import threading
import time
import uuid
from pathlib import Path

from skhybrid.experiments.run._progress_lines import (
    SearchClock,
    count,
    duration,
    event_line,
    fit_line,
)

__all__ = [
    "DaskEventSink",
    "FileSink",
    "ProgressBars",
    "Tagged",
    "attach_epoch_logger",
    "epoch_budget",
    "physics_event",
    "physics_hook",
]

#: Least time between two events of one physics fit (the first always goes).
PHYSICS_EVENT_INTERVAL = 0.5
#: Most seconds a log goes without a line while the run works.
LOG_INTERVAL = 15.0
#: Seconds between two reads of the sink in the run's process.
POLL_INTERVAL = 0.5


def physics_event(label, nfev, max_nfev, n_records, unit="record"):
    """The event of a physics fit's progress (see :func:`physics_hook`)."""
    return {
        "kind": "physics",
        "label": label,
        "nfev": int(nfev),
        "max_nfev": None if max_nfev is None else int(max_nfev),
        "n_records": int(n_records),
        "unit": unit,
    }


def physics_hook(sink, label, unit="record"):
    """A :func:`skhybrid.domain.fit_progress` hook that reports to ``sink``.

    Parameters
    ----------
    sink : FileSink, DaskEventSink or Tagged
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


def _as_event(event):
    # A bare name is an epoch of that model (what a user's callback may send).
    return {"kind": "epoch", "name": event} if isinstance(event, str) else event


def _encode(event):
    return json.dumps(_as_event(event), default=str)


def _decode(line):
    try:
        event = json.loads(line)
    except ValueError:
        return _as_event(line)
    return event if isinstance(event, dict) else _as_event(line)


class Tagged:
    """A sink that adds ``tags`` to every event sent through it.

    Parameters
    ----------
    sink : FileSink, DaskEventSink or Tagged
        Where the events go.
    **tags
        Added to each event (an event's own keys win): the fit's ``seed``,
        ``model``, ``where`` (its fold) and ``candidate``.
    """

    def __init__(self, sink, **tags):
        self.sink = sink
        self.tags = tags

    def emit(self, event):
        self.sink.emit({**self.tags, **_as_event(event)})


class FileSink:
    """Append each event to the file ``path`` (one machine, many processes)."""

    def __init__(self, path):
        self.path = str(path)
        self._offset = 0

    def __getstate__(self):
        return {"path": self.path}

    def __setstate__(self, state):
        self.__init__(state["path"])

    def emit(self, event):
        try:
            with open(self.path, "a") as f:
                f.write(f"{_encode(event)}\n")
        except OSError:  # the run's progress folder is gone: progress is optional
            pass

    def drain(self):
        """The events written since the last call (whole lines only)."""
        try:
            with open(self.path, "rb") as f:
                f.seek(self._offset)
                data = f.read()
        except OSError:
            return []
        end = data.rfind(b"\n") + 1  # a line still being written waits
        self._offset += end
        text = data[:end].decode("utf-8", errors="replace")
        return [_decode(line) for line in text.splitlines() if line]

    def count(self):
        """Epochs reported so far."""
        try:
            with open(self.path) as f:
                return sum(
                    _decode(line.rstrip("\n")).get("kind") == "epoch" for line in f
                )
        except OSError:
            return 0


class DaskEventSink:
    """Log each event on the Dask scheduler under ``topic`` (a cluster).

    In the client, :meth:`subscribe` receives the events of the topic; on a
    worker, :meth:`emit` logs one. Outside a Dask worker, :meth:`emit` does
    nothing.
    """

    def __init__(self, topic):
        self.topic = topic
        self._count = 0
        self._events = []
        self._lock = threading.Lock()

    def __getstate__(self):
        return {"topic": self.topic}

    def __setstate__(self, state):
        self.__init__(state["topic"])

    def emit(self, event):
        try:
            from distributed import get_worker

            worker = get_worker()
        except (ImportError, ValueError):
            return
        worker.log_event(self.topic, _encode(event))

    def _on_event(self, event):
        message = event[1] if isinstance(event, tuple) else event
        decoded = _decode(message) if isinstance(message, str) else None
        if decoded is None:
            return
        with self._lock:
            self._events.append(decoded)
            self._count += decoded.get("kind") == "epoch"

    def subscribe(self, client):
        client.subscribe_topic(self.topic, self._on_event)
        self._client = client
        return self

    def unsubscribe(self):
        client = getattr(self, "_client", None)
        if client is not None:
            client.unsubscribe_topic(self.topic)

    def drain(self):
        """The events received since the last call."""
        with self._lock:
            events, self._events = self._events, []
        return events

    def count(self):
        """Epochs reported so far."""
        with self._lock:
            return self._count


def attach_epoch_logger(estimator, sink, name):
    """Report every epoch of the networks inside ``estimator`` to ``sink``.

    Parameters
    ----------
    estimator : estimator
        A network, or a composite holding networks (their ``callbacks``).
    sink : FileSink, DaskEventSink, Tagged, str or Path
        Where the epochs go; a path means a :class:`FileSink`.
    name : str
        The model's name.

    Returns
    -------
    estimator : estimator
        ``estimator``, each network given an
        :class:`~skhybrid.neural.EpochProgress`.
    """
    from skhybrid.neural import EpochProgress

    if isinstance(sink, (str, Path)):
        sink = FileSink(sink)
    keys = [
        key
        for key in estimator.get_params(deep=True)
        if key == "callbacks" or key.endswith("__callbacks")
    ]
    for key in keys:
        estimator.set_params(**{key: [EpochProgress(sink, name)]})
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
    """Progress on standard error: fitted models, epochs, folds, time left.

    On a terminal, three tqdm bars: models of the run's total (with the
    current search's fold fits and the time it has left), epochs of the
    networks (of their largest possible total where it is known, with the
    latest epoch's loss), and the latest physics fit's residual evaluations
    of its ``max_nfev``. Elsewhere (a log file, CI), lines:

    - when the fits start, and when a model's search (or refit) begins;
    - when each fit of a fold, or a refit, ends: the model, its candidate,
      the fold and the seed, and once a fold has ended the time the model's
      search has left (:class:`~skhybrid.experiments.run._progress_lines.SearchClock`);
    - one per finished model;
    - and never ``log_interval`` seconds without a line: when nothing else was
      written, the latest news (a network's epoch of its most, with its
      validation loss; a physics fit's evaluations), with the time elapsed.

    Parameters
    ----------
    n_models : int
        Models in the run.
    description : str
        Prefix of the bars and lines.
    client : distributed.Client or None, default=None
        With a Dask client, events come from Dask; without, from a temporary
        file.
    n_done : int, default=0
        Models already finished (a resumed run).
    n_epochs : int or None, default=None
        Most epochs the run's networks can take (see :func:`epoch_budget`);
        None where it is not known before the fits.
    stream : file-like or None, default=None
        Where progress goes; None is ``sys.stderr``.
    log_interval : float or None, default=None
        Most seconds between two lines outside a terminal; None is
        ``LOG_INTERVAL`` (15 s).
    clock : callable or None, default=None
        Seconds as a float (``time.monotonic`` where None): a test's clock.
    poll_interval : float or None, default=POLL_INTERVAL
        Seconds between two reads of the events by a background thread; None
        starts no thread (the caller calls :meth:`update`).
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
        log_interval=None,
        clock=None,
        poll_interval=POLL_INTERVAL,
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
            path = Path(self._dir.name) / "events.log"
            path.touch()
            self.sink = FileSink(path)
        else:
            self.sink = DaskEventSink(f"skhybrid-epochs-{uuid.uuid4().hex}")
            self.sink.subscribe(client)
        self.models = self.epochs = self.physics = None
        self.clock = time.monotonic if clock is None else clock
        self.log_interval = (
            LOG_INTERVAL if log_interval is None else float(log_interval)
        )
        self.poll_interval = poll_interval
        self._started = self._last_line = self._latest_at = self.clock()
        self._latest = None  # the latest epoch, physics or fit-start event
        self._searches = {}  # (seed, model) -> SearchClock
        self._running = {}  # (seed, model) -> fits running
        self._n_epochs_seen = 0
        self._write_lock = threading.Lock()
        self._update_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None
        if poll_interval is not None:
            self._thread = threading.Thread(target=self._watch, daemon=True)
        if not self.interactive:
            # A first line at once: a log shows the run has started.
            done = f", {n_done} already finished" if n_done else ""
            self._write(f"{count(n_models, 'model')} to fit{done}")
        else:
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
        if self._thread is not None:
            self._thread.start()

    # -- reading the events ------------------------------------------------------
    def _watch(self):
        while not self._stop.wait(self.poll_interval):
            self.update()

    def update(self, news=True):
        """Read the new events; in a log, write what they say, or the latest news.

        Called every ``poll_interval`` seconds by the background thread; a
        line is written whenever ``log_interval`` seconds would otherwise pass
        without one.

        Parameters
        ----------
        news : bool, default=True
            Write the latest news when the log has been quiet for
            ``log_interval`` seconds (False: only what the new events say).
        """
        with self._update_lock:
            for event in self.sink.drain():
                self._handle(event)
            if self.epochs is not None:
                self.epochs.update(self._n_epochs_seen - self.epochs.n)
            if self.interactive or not news:
                return
            now = self.clock()
            # Early by one poll: the next read may come a poll too late.
            due = self.log_interval - (self.poll_interval or 0.0)
            if now - self._last_line >= due:
                self._write(self._news(now))

    # Kept for callers of the earlier name.
    _update = update

    def _handle(self, event):
        kind = event.get("kind")
        if kind in ("epoch", "physics"):
            self._latest, self._latest_at = event, self.clock()
            if kind == "epoch":
                self._n_epochs_seen += 1
                if self.epochs is not None:
                    self.epochs.set_postfix_str(event_line(event), refresh=False)
            elif self.physics is not None:
                self.physics.total = event.get("max_nfev")
                self.physics.n = event["nfev"]
                self.physics.set_postfix_str(
                    f"{event['label']}; "
                    f"{count(event['n_records'], event.get('unit', 'record'))} "
                    "simulated",
                    refresh=False,
                )
                self.physics.refresh()
        elif kind == "search":
            self._search_begins(event)
        elif kind == "fit":
            self._fit_event(event)

    def _search_begins(self, event):
        key = (event.get("seed"), event.get("model"))
        n_candidates = int(event.get("n_candidates") or 0)
        n_folds = int(event.get("n_folds") or 1)
        self._searches = {k: v for k, v in self._searches.items() if k[0] != key[0]}
        # One search at a time per seed: the fits of other models (a shared
        # physics refitted on a fold) are shown, not counted in its estimate.
        self._searches[key] = SearchClock(
            n_candidates, n_folds, event.get("n_workers") or 1
        )
        seed = "" if event.get("seed") is None else f" at seed {event['seed']}"
        if event.get("searched_at") is not None:
            text = (
                f"{event['model']}{seed}: refitting on the whole records the "
                f"choice made at seed {event['searched_at']}"
            )
        elif n_candidates:
            text = (
                f"{event['model']}{seed}: searching {count(n_candidates, 'candidate')}"
                f" on {count(n_folds, 'fold')} ({n_candidates * n_folds} fits, "
                f"{event.get('n_workers') or 1} at a time), then a refit on the "
                "whole records"
            )
        else:
            text = f"{event['model']}{seed}: chosen from the other models' folds"
        if not self.interactive:
            self._write(text)

    def _fit_event(self, event):
        key = (event.get("seed"), event.get("model"))
        if event.get("state") == "start":
            self._latest, self._latest_at = event, self.clock()
            self._running[key] = self._running.get(key, 0) + 1
            return
        self._latest, self._latest_at = event, self.clock()
        self._running[key] = max(0, self._running.get(key, 0) - 1)
        search = self._searches.get(key)
        estimate = None
        if search is not None:
            search.record(event)
            estimate = search.remaining()
            event = {**event, "progress": search.progress()}
            if estimate == 0:
                estimate = None
        if self.models is not None:
            left = "" if estimate is None else f", about {duration(estimate)} left"
            self.models.set_postfix_str(
                f"{event.get('model')}: {event.get('progress') or 'refit'}{left}"
            )
        else:
            self._write(fit_line(event, estimate))

    def _news(self, now):
        """The latest news, for a log that would otherwise stay quiet."""
        elapsed = f"{duration(now - self._started)} into the run"
        if self._latest is None:
            return f"working, no fit has reported yet ({elapsed})"
        age = now - self._latest_at
        since = f"; latest news {duration(age)} ago" if age >= self.log_interval else ""
        running = sum(self._running.values())
        also = f"; {running} fits running" if running > 1 else ""
        return f"{event_line(self._latest)} ({elapsed}{since}{also})"

    def _write(self, text):
        with self._write_lock:
            self.stream.write(f"{self.description}: {text}\n")
            self.stream.flush()
            self._last_line = self.clock()

    # -- the parent's own news ---------------------------------------------------
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
        # The model's own fits (read from the sink) are written before it.
        self.update(news=False)
        epochs = "" if n_epochs is None else f", {n_epochs} epochs"
        if seed is not None:
            name = f"{name} at seed {seed}"
        if searched_at is not None:
            name = f"{name} (refit of the choice made at seed {searched_at})"
        self.n_done += 1
        if self.models is None:
            self._write(
                f"{self.n_done}/{self.n_models} models: {name} ({fit_time:.1f} s"
                f"{epochs})"
            )
            return
        self.models.set_postfix_str(f"{name} ({fit_time:.1f} s{epochs})")
        self.models.update()

    def close(self):
        """Stop reading and close the bars, leaving the terminal clean."""
        self._stop.set()
        if self._thread is not None and self._thread.is_alive():
            self._thread.join()
        self.update(news=False)  # the last events: their lines, the epochs' total
        if self.physics is not None:
            self.physics.close()
        if self.epochs is not None:
            self.epochs.update(self._n_epochs_seen - self.epochs.n)
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
