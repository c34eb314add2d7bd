"""Loaders of measured system-identification benchmarks from a local folder.

The data are not shipped with the package and never downloaded: the caller names
the folder that holds them (for example a clone's ``../shared/data``).
"""

from pathlib import Path

import numpy as np
from scipy.io import loadmat
from sklearn.utils import Bunch

__all__ = ["load_cascaded_tanks", "load_emps", "load_silverbox"]


def _find_file(path, subfolder, filename, loader):
    """``path/filename`` or ``path/subfolder/filename``; a clear error otherwise."""
    if not isinstance(path, (str, Path)):
        raise TypeError(
            f"path must be a str or pathlib.Path naming a folder; got "
            f"{type(path).__name__} {path!r}."
        )
    folder = Path(path)
    for candidate in (folder / filename, folder / subfolder / filename):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(
        f"{loader} could not find {filename} in path={str(path)!r} nor in its "
        f"{subfolder}/ subfolder; pass the folder holding the benchmark files."
    )


def _column(array):
    return np.asarray(array, dtype=float).reshape(-1, 1)


def _split(u, y, index=slice(None)):
    return Bunch(u=_column(u)[index], y=_column(y)[index])


_SILVERBOX_DESCR = """\
Silverbox: an electronic Duffing oscillator (measured)
------------------------------------------------------

An electrical circuit implementing m y'' + d y' + (a + b y^2) y = u, a
second-order linear system with a cubic feedback nonlinearity. Input V1, the
excitation voltage (V); output V2, the measured output voltage (V).
131072 samples at fs = 1e7 / 2^14 = 610.35 Hz (dt = 1.6384 ms). Samples
0..~40500 are the "arrow" (filtered Gaussian noise of growing amplitude, whose
tip exceeds the training amplitude), followed by 10 odd random-phase
multisines. The official splits (nonlinear-benchmarks v1.0.1), 0-based and
half-open: train [40650:105712], test_multisine [105712:127400],
test_arrow_full [100:40575], test_arrow_no_extrapolation [100:32100]; the first
n_init = 50 samples of a test may initialise the model's state, and the RMSE is
taken over the rest, in free-run simulation.

Cite: T. Wigren, J. Schoukens, "Three free data sets for development and
benchmarking in nonlinear system identification", European Control Conference
(ECC) 2013, pp. 2933-2938.
"""

_SILVERBOX_SPLITS = {
    "train": (40650, 105712),
    "test_multisine": (105712, 127400),
    "test_arrow_full": (100, 40575),
    "test_arrow_no_extrapolation": (100, 32100),
}


def load_silverbox(path):
    """Load the Silverbox benchmark (an electronic Duffing oscillator).

    Parameters
    ----------
    path : str or pathlib.Path
        Folder holding ``SNLS80mV.mat``, or its parent holding ``silverbox/``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        u, y : ndarray of shape (131072, 1)
            The whole record: input voltage ``V1`` and output voltage ``V2`` (V).
        splits : dict of str to Bunch
            ``"train"``, ``"test_multisine"``, ``"test_arrow_full"`` and
            ``"test_arrow_no_extrapolation"``, each a Bunch of ``u`` and ``y``
            sliced from the record by the official indices.
        split_indices : dict of str to (int, int)
            The official half-open, 0-based index ranges of the splits.
        n_init : int
            Samples at the start of a test split that may initialise a model's
            state (50).
        dt : float
            Sample period (s), ``2**14 / 1e7``.
        input_names, output_names : list of str
            ``["V1"]`` and ``["V2"]``.
        DESCR : str
            Description, splits and citation.

    See Also
    --------
    load_cascaded_tanks : Another measured benchmark.

    Notes
    -----
    The official loader (``nonlinear-benchmarks`` on PyPI) simulates in free run
    and reports ``RMSE(y[n_init:], y_model[n_init:])`` on each test split. For the
    one-step window convention, cut a split with
    :func:`skhybrid.preprocessing.make_windows` (``states=y``, ``inputs=u``).

    Examples
    --------
    >>> from skhybrid.datasets import load_silverbox
    >>> data = load_silverbox("path/to/shared/data")  # doctest: +SKIP
    >>> data.splits["train"].u.shape  # doctest: +SKIP
    (65062, 1)
    """
    file = _find_file(path, "silverbox", "SNLS80mV.mat", "load_silverbox")
    mat = loadmat(file)
    u, y = _column(mat["V1"]), _column(mat["V2"])
    splits = {
        name: _split(u, y, slice(*idx)) for name, idx in _SILVERBOX_SPLITS.items()
    }
    return Bunch(
        u=u,
        y=y,
        splits=splits,
        split_indices=dict(_SILVERBOX_SPLITS),
        n_init=50,
        dt=2**14 / 1e7,
        input_names=["V1"],
        output_names=["V2"],
        DESCR=_SILVERBOX_DESCR,
    )


_TANKS_DESCR = """\
Cascaded tanks with overflow (measured)
---------------------------------------

Water is pumped into an upper tank, flows into a lower tank and out of it; the
water level of the lower tank is measured (uncalibrated sensor, V; SNR about
40 dB). Input u: pump voltage (V); output y: lower-tank level (V), which clips
at 10 V when the tank overflows. Two records of 1024 samples each at Ts = 4 s,
with ZOH multisine inputs up to 0.0144 Hz and the same unknown initial state:
the estimation record (uEst, yEst) is the official training split and the
validation record (uVal, yVal) the test split; n_init = 50 samples of the test
may initialise the state (nonlinear-benchmarks v1.0.1; the original benchmark
note uses all 1024 samples). Physics (benchmark note):
x1' = -k1 sqrt(x1) + k4 u, x2' = k2 sqrt(x1) - k3 sqrt(x2), y = x2, without the
overflow.

Cite: M. Schoukens, P. Mattsson, T. Wigren, J.P. Noel, "Cascaded tanks
benchmark combining soft and hard nonlinearities", Workshop on Nonlinear System
Identification Benchmarks, Brussels, 2016.
"""


def load_cascaded_tanks(path):
    """Load the cascaded-tanks benchmark (water levels with overflow).

    Parameters
    ----------
    path : str or pathlib.Path
        Folder holding ``dataBenchmark.mat``, or its parent holding
        ``cascaded_tanks/``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        splits : dict of str to Bunch
            ``"train"`` (the estimation record ``uEst``, ``yEst``) and ``"test"``
            (the validation record ``uVal``, ``yVal``), each a Bunch of ``u`` and
            ``y`` of shape (1024, 1).
        n_init : int
            Samples at the start of the test split that may initialise a model's
            state (50).
        dt : float
            Sample period (s), 4.0.
        input_names, output_names : list of str
            ``["pump_voltage"]`` and ``["lower_tank_level"]``.
        DESCR : str
            Description, splits and citation.

    See Also
    --------
    load_silverbox : Another measured benchmark.

    Examples
    --------
    >>> from skhybrid.datasets import load_cascaded_tanks
    >>> data = load_cascaded_tanks("path/to/shared/data")  # doctest: +SKIP
    >>> data.splits["test"].y.shape  # doctest: +SKIP
    (1024, 1)
    """
    file = _find_file(
        path, "cascaded_tanks", "dataBenchmark.mat", "load_cascaded_tanks"
    )
    mat = loadmat(file)
    return Bunch(
        splits={
            "train": _split(mat["uEst"], mat["yEst"]),
            "test": _split(mat["uVal"], mat["yVal"]),
        },
        n_init=50,
        dt=float(np.asarray(mat["Ts"]).item()),
        input_names=["pump_voltage"],
        output_names=["lower_tank_level"],
        DESCR=_TANKS_DESCR,
    )


_EMPS_DESCR = """\
EMPS: electro-mechanical positioning system (measured, closed loop)
-------------------------------------------------------------------

A DC motor drives a prismatic joint through a ball screw; the position is
controlled by a cascaded P/PI loop. Input u: the controller output vir (V; the
motor force is gtau * vir with gtau = 35.15 N/V); output y: the measured motor
position qm (m, load side). About 24841 samples at 1 kHz. The official training
split is DATA_EMPS.mat and the test split DATA_EMPS_PULSES.mat (the same
trajectory with added force pulses); n_init = 20; report the RMSE in mm. The
plant contains a pure integrator, so free-run simulation from vir drifts.
Physics (description): M q'' = gtau vir - Fv q' - Fc sign(q') - offset, with the
reference estimates M = 95.1089 kg, Fv = 203.5034 N s/m, Fc = 20.3935 N and
offset = -3.1648 N.

Cite: A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models of EMPS",
Workshop on Nonlinear System Identification Benchmarks, Eindhoven, 2019.
"""


def load_emps(path):
    """Load the EMPS benchmark (a DC-motor-driven positioning axis, closed loop).

    Parameters
    ----------
    path : str or pathlib.Path
        Folder holding ``DATA_EMPS.mat`` and ``DATA_EMPS_PULSES.mat``, or its
        parent holding ``emps/``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        splits : dict of str to Bunch
            ``"train"`` (``DATA_EMPS.mat``) and ``"test"``
            (``DATA_EMPS_PULSES.mat``), each a Bunch of ``u`` (``vir``, V), ``y``
            (``qm``, m), ``t`` (s) and ``reference`` (``qg``, m), arrays of shape
            (n_times, 1).
        controller : dict
            ``gtau`` (N/V), ``kp`` (1/s) and ``kv`` (V s/m) of the recording.
        n_init : int
            Samples at the start of the test split that may initialise a model's
            state (20).
        dt : float
            Sample period (s), 0.001.
        input_names, output_names : list of str
            ``["vir"]`` and ``["qm"]``.
        DESCR : str
            Description, splits and citation.

    See Also
    --------
    load_silverbox : Another measured benchmark.

    Examples
    --------
    >>> from skhybrid.datasets import load_emps
    >>> data = load_emps("path/to/shared/data")  # doctest: +SKIP
    >>> sorted(data.splits)  # doctest: +SKIP
    ['test', 'train']
    """
    splits = {}
    for name, filename in (
        ("train", "DATA_EMPS.mat"),
        ("test", "DATA_EMPS_PULSES.mat"),
    ):
        mat = loadmat(_find_file(path, "emps", filename, "load_emps"))
        split = _split(mat["vir"], mat["qm"])
        split.t = _column(mat["t"])
        split.reference = _column(mat["qg"])
        splits[name] = split
    return Bunch(
        splits=splits,
        controller={k: float(np.asarray(mat[k]).item()) for k in ("gtau", "kp", "kv")},
        n_init=20,
        # The nominal 1 kHz of the description (the stored t is rounded).
        dt=1e-3,
        input_names=["vir"],
        output_names=["qm"],
        DESCR=_EMPS_DESCR,
    )
