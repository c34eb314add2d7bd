"""Progress over models and epochs for fits that run in joblib worker processes.

Each network gets an :class:`EpochLogger` callback that appends one line per epoch
to a file; the parent process counts the lines in a thread and moves a progress bar.
A file path pickles into any worker, where a queue or a lock would not.
"""

import tempfile
import threading
from pathlib import Path

from skorch.callbacks import Callback

__all__ = ["EpochLogger", "ProgressBars", "attach_epoch_logger"]


class EpochLogger(Callback):
    """skorch callback: append ``name`` to the file ``path`` after every epoch."""

    def __init__(self, path, name):
        self.path = path
        self.name = name

    def on_epoch_end(self, net, **kwargs):
        with open(self.path, "a") as f:
            f.write(f"{self.name}\n")


def attach_epoch_logger(estimator, path, name):
    """Add an :class:`EpochLogger` to every network inside ``estimator``."""
    keys = [
        key
        for key in estimator.get_params(deep=True)
        if key == "callbacks" or key.endswith("__callbacks")
    ]
    for key in keys:
        estimator.set_params(**{key: [EpochLogger(str(path), name)]})
    return estimator


class ProgressBars:
    """Two tqdm bars on standard error: fitted models, and epochs of all networks."""

    def __init__(self, n_models, description):
        from tqdm.auto import tqdm

        self._dir = tempfile.TemporaryDirectory(prefix="skhybrid-progress-")
        self.path = Path(self._dir.name) / "epochs.log"
        self.path.touch()
        self.models = tqdm(total=n_models, desc=f"{description}: models", unit="model")
        self.epochs = tqdm(desc=f"{description}: epochs", unit="epoch", position=1)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def _count(self):
        with self.path.open() as f:
            return sum(1 for _ in f)

    def _watch(self):
        while not self._stop.wait(0.5):
            self.epochs.update(self._count() - self.epochs.n)

    def model_done(self, name, fit_time, n_epochs):
        epochs = "" if n_epochs is None else f", {n_epochs} epochs"
        self.models.set_postfix_str(f"{name} ({fit_time:.1f} s{epochs})")
        self.models.update()

    def close(self):
        self._stop.set()
        self._thread.join()
        self.epochs.update(self._count() - self.epochs.n)
        self.epochs.close()
        self.models.close()
        self._dir.cleanup()
