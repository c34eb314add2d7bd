"""Fixtures shared by the experiments' tests."""

import signal

import pytest
from skorch.callbacks import Callback


class CtrlCAtEpoch(Callback):
    """Send this process a SIGINT (a Ctrl-C) at the end of epoch ``epoch``."""

    def __init__(self, epoch):
        self.epoch = epoch

    def on_epoch_end(self, net, **kwargs):
        if len(net.history) == self.epoch:
            signal.raise_signal(signal.SIGINT)


@pytest.fixture
def ctrl_c_at_epoch():
    """The skorch callback that presses Ctrl-C during a network's training.

    skorch catches the KeyboardInterrupt inside ``fit`` and returns the network
    as if trained: a run must still stop and not record that model. The test
    runs with Python's own SIGINT handler, as in a terminal: the suite itself
    may run as a background job of a script, which ignores SIGINT.
    """
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield CtrlCAtEpoch
    signal.signal(signal.SIGINT, previous)


@pytest.fixture
def benchmark_script():
    """A loader of a script of ``benchmarks/`` as a module, by its file name."""
    import importlib.util
    from pathlib import Path

    folder = Path(__file__).parents[2] / "benchmarks"

    def load(name):
        spec = importlib.util.spec_from_file_location(Path(name).stem, folder / name)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    return load
