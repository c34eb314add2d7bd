"""Progress over models and epochs for fits that run in other processes or machines.

Each network gets an :class:`EpochLogger` callback that reports one event per
epoch to a sink that pickles into any worker:

- :class:`FileSink` appends a line to a file, for joblib's worker processes on this
  machine (the parent counts the lines);
- :class:`DaskEventSink` logs a Dask event on the worker's scheduler, for workers
  on a cluster (the client subscribes to the topic), where no file is shared.

The bar over models moves as each model's result comes back to the parent, with
any backend.
"""

import tempfile
import threading
import uuid
from pathlib import Path

from skorch.callbacks import Callback

__all__ = [
    "DaskEventSink",
    "EpochLogger",
    "FileSink",
    "ProgressBars",
    "attach_epoch_logger",
]


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

    def count(self):
        try:
            with open(self.path) as f:
                return sum(1 for _ in f)
        except OSError:
            return 0


class DaskEventSink:
    """Log each event on the Dask scheduler under ``topic`` (a cluster).

    In the client, :meth:`subscribe` counts the events of the topic; on a worker,
    :meth:`emit` logs one. Outside a Dask worker, :meth:`emit` does nothing.
    """

    def __init__(self, topic):
        self.topic = topic
        self._count = 0
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
        with self._lock:
            self._count += 1

    def subscribe(self, client):
        client.subscribe_topic(self.topic, self._on_event)
        self._client = client
        return self

    def unsubscribe(self):
        client = getattr(self, "_client", None)
        if client is not None:
            client.unsubscribe_topic(self.topic)

    def count(self):
        with self._lock:
            return self._count


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


class ProgressBars:
    """Two tqdm bars on standard error: fitted models, and epochs of all networks.

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
    """

    def __init__(self, n_models, description, *, client=None, n_done=0):
        from tqdm.auto import tqdm

        self._dir = None
        if client is None:
            self._dir = tempfile.TemporaryDirectory(prefix="skhybrid-progress-")
            path = Path(self._dir.name) / "epochs.log"
            path.touch()
            self.sink = FileSink(path)
        else:
            self.sink = DaskEventSink(f"skhybrid-epochs-{uuid.uuid4().hex}")
            self.sink.subscribe(client)
        self.models = tqdm(
            total=n_models, initial=n_done, desc=f"{description}: models", unit="model"
        )
        self.epochs = tqdm(desc=f"{description}: epochs", unit="epoch", position=1)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def _watch(self):
        while not self._stop.wait(0.5):
            self.epochs.update(self.sink.count() - self.epochs.n)

    def model_done(self, name, fit_time, n_epochs):
        epochs = "" if n_epochs is None else f", {n_epochs} epochs"
        self.models.set_postfix_str(f"{name} ({fit_time:.1f} s{epochs})")
        self.models.update()

    def close(self):
        self._stop.set()
        self._thread.join()
        self.epochs.update(self.sink.count() - self.epochs.n)
        self.epochs.close()
        self.models.close()
        if isinstance(self.sink, DaskEventSink):
            self.sink.unsubscribe()
        if self._dir is not None:
            self._dir.cleanup()
