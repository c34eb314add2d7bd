"""Loaders of measured system-identification benchmarks from a local folder.

The data are not shipped with the package and never downloaded: the caller names
the folder that holds them (for example a clone's ``../shared/data``).
"""

import json
from pathlib import Path

import numpy as np
from scipy.io import loadmat
from sklearn.utils import Bunch

__all__ = [
    "load_cascaded_tanks",
    "load_coupled_electric_drives",
    "load_emps",
    "load_friction_damper",
    "load_silverbox",
    "load_wiener_hammerstein",
]


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


class _MatFile:
    """The variables of one ``.mat`` file, checked at the boundary.

    Every check raises one ValueError that names the loader, the file, the
    variable and the value received, before any model sees the data: a corrupt
    file must not run to completion with a silent wrong answer (a sample period
    of 0 freezes a simulation at its start values).
    """

    def __init__(self, file, loader):
        self.file, self.loader = Path(file), loader
        try:
            self.mat = loadmat(self.file)
        except Exception as exc:  # scipy raises MatReadError, OSError, ValueError
            raise ValueError(
                f"{loader}: {self.file} is not a readable MATLAB .mat file "
                f"({type(exc).__name__}: {exc}); it may be truncated, empty or "
                f"of another format. Replace it with the benchmark's original file."
            ) from exc

    def _fail(self, name, problem):
        raise ValueError(f"{self.loader}: {self.file}: variable {name!r} {problem}.")

    def _array(self, name):
        if name not in self.mat:
            present = sorted(k for k in self.mat if not k.startswith("__"))
            self._fail(name, f"is missing; the file holds {present}")
        value = self.mat[name]
        try:
            return np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            self._fail(
                name, f"must be numeric; got {type(value).__name__} {value!r:.80}"
            )

    def vector(self, name):
        """The variable as a finite column of shape (n_times, 1)."""
        array = self._array(name)
        if array.ndim > 2 or (array.ndim == 2 and min(array.shape) != 1):
            self._fail(
                name,
                f"must be a vector (one row or one column); got shape {array.shape}",
            )
        column = array.reshape(-1, 1)
        if column.shape[0] == 0:
            self._fail(name, "is empty; got shape " + str(array.shape))
        bad = np.flatnonzero(~np.isfinite(column[:, 0]))
        if bad.size:
            self._fail(
                name,
                f"must hold finite values; got {name}[{bad[0]}]="
                f"{float(column[bad[0], 0])!r} ({bad.size} non-finite of "
                f"{column.shape[0]})",
            )
        return column

    def scalar(self, name, *, positive=False, what="value"):
        """The variable as one finite float (positive where asked)."""
        array = self._array(name)
        if array.size != 1:
            self._fail(name, f"must be a single {what}; got shape {array.shape}")
        value = float(array.item())
        if not np.isfinite(value) or (positive and value <= 0):
            allowed = "a positive finite" if positive else "a finite"
            self._fail(name, f"must be {allowed} {what}; got {name}={value!r}")
        return value

    def record(self, u_name, y_name, n_init):
        """Input and output columns of equal length, at least ``n_init + 1`` long."""
        u, y = self.vector(u_name), self.vector(y_name)
        if u.shape[0] != y.shape[0]:
            self._fail(
                y_name,
                f"must have as many samples as the input {u_name!r}; got "
                f"{y.shape[0]} samples and {u_name} has {u.shape[0]}",
            )
        what = f"{self.loader}: {self.file}: variable {y_name!r}"
        _check_record_length(u.shape[0], n_init, what)
        return u, y


def _check_record_length(n_samples, n_init, what):
    """Raise when a record cannot hold ``n_init`` initial samples and one more."""
    if n_samples < n_init + 1:
        raise ValueError(
            f"{what} has {n_samples} samples; a record needs at least "
            f"n_init + 1 = {n_init + 1} (n_init={n_init} samples initialise a "
            f"model's state and at least one is predicted)."
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

    Raises
    ------
    FileNotFoundError
        When the file is in neither ``path`` nor its subfolder.
    ValueError
        When a file is not a readable ``.mat`` file, a variable is missing, not a
        vector or not finite, inputs and outputs differ in length, a record is
        shorter than ``n_init + 1`` or than the official splits need; the message
        names the file, the variable and the value received.

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
    mat = _MatFile(file, "load_silverbox")
    u, y = mat.record("V1", "V2", 50)
    # The official splits index the whole record: it must reach their ends (each
    # split is then longer than n_init + 1).
    end = max(stop for _, stop in _SILVERBOX_SPLITS.values())
    if u.shape[0] < end:
        mat._fail(
            "V2",
            f"has {u.shape[0]} samples; the official splits need at least {end} "
            f"(the end of test_multisine)",
        )
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

    Raises
    ------
    FileNotFoundError
        When the file is in neither ``path`` nor its subfolder.
    ValueError
        When a file is not a readable ``.mat`` file, a variable is missing, not a
        vector or not finite, inputs and outputs differ in length, a record is
        shorter than ``n_init + 1`` or the sample period ``Ts`` is not positive; the
        message names the file, the variable and the value received.

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
    mat = _MatFile(file, "load_cascaded_tanks")
    n_init = 50
    splits = {
        "train": _split(*mat.record("uEst", "yEst", n_init)),
        "test": _split(*mat.record("uVal", "yVal", n_init)),
    }
    dt = mat.scalar("Ts", positive=True, what="sample period (s)")
    return Bunch(
        splits=splits,
        n_init=n_init,
        dt=dt,
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

    Raises
    ------
    FileNotFoundError
        When the file is in neither ``path`` nor its subfolder.
    ValueError
        When a file is not a readable ``.mat`` file, a variable is missing, not a
        vector or not finite, inputs and outputs differ in length, a record is
        shorter than ``n_init + 1`` or the time stamps ``t`` do not increase (a
        sample period that is not positive); the message names the file, the
        variable and the value received.

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
    n_init = 20
    for name, filename in (
        ("train", "DATA_EMPS.mat"),
        ("test", "DATA_EMPS_PULSES.mat"),
    ):
        mat = _MatFile(_find_file(path, "emps", filename, "load_emps"), "load_emps")
        split = _split(*mat.record("vir", "qm", n_init))
        for key, variable in (("t", "t"), ("reference", "qg")):
            column = mat.vector(variable)
            if column.shape[0] != split.y.shape[0]:
                mat._fail(
                    variable,
                    f"must have as many samples as the output 'qm'; got "
                    f"{column.shape[0]} samples and qm has {split.y.shape[0]}",
                )
            split[key] = column
        # The time stamps carry the sample period: each step must be positive.
        steps = np.diff(split.t[:, 0])
        if steps.size and steps.min() <= 0:
            k = int(np.argmin(steps))
            mat._fail(
                "t",
                f"must increase at every sample (the sample period is "
                f"t[k + 1] - t[k] > 0); got t[{k + 1}] - t[{k}] = "
                f"{float(steps[k]):.6g} s",
            )
        splits[name] = split
    controller = {
        k: mat.scalar(k, what="controller constant") for k in ("gtau", "kp", "kv")
    }
    return Bunch(
        splits=splits,
        controller=controller,
        n_init=n_init,
        # The nominal 1 kHz of the description (the stored t is rounded).
        dt=1e-3,
        input_names=["vir"],
        output_names=["qm"],
        DESCR=_EMPS_DESCR,
    )


_CED_DESCR = """\
Coupled electric drives (measured)
----------------------------------

Two motors drive a pulley through a flexible belt; the input is the sum of the
motors' voltages, the output the pulley's speed, measured by a pulse counter
that cannot sense the sign of the velocity (so the output is the absolute value)
and low-pass filtered. DATAUNIF holds two records of 500 samples at Ts = 20 ms
with a uniformly distributed input: record 1 (u11 -> z11, "low" amplitude) and
record 2 (u12 = u11 + 0.5 -> z12, "high"). The official split
(nonlinear-benchmarks v1.0.1) trains on samples [:400] of each record and tests
on [400:], with n_init = 10; the two test RMSEs are reported separately.

Cite: T. Wigren, M. Schoukens, "Coupled Electric Drives Data Set and Reference
Models", Technical Report 2017-024, Dept. of Information Technology, Uppsala
University, 2017.
"""


def load_coupled_electric_drives(path):
    """Load the Coupled Electric Drives benchmark (DATAUNIF, both records).

    Parameters
    ----------
    path : str or pathlib.Path
        Folder holding ``DATAUNIF.MAT``, or its parent holding
        ``coupled_electric_drives/``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        splits : dict of str to Bunch
            ``"train_1"``, ``"test_1"`` (record 1, ``u11`` -> ``z11``) and
            ``"train_2"``, ``"test_2"`` (record 2, ``u12`` -> ``z12``): samples
            ``[:400]`` and ``[400:]`` of each, a Bunch of ``u`` and ``y`` each.
        n_init : int
            Samples at the start of a test split that may initialise a model's
            state (10).
        dt : float
            Sample period (s), 0.02.
        input_names, output_names : list of str
            ``["voltage"]`` and ``["pulley_speed"]``.
        DESCR : str
            Description, splits and citation.

    Raises
    ------
    FileNotFoundError
        When the file is in neither ``path`` nor its subfolder.
    ValueError
        When the file is not a readable ``.mat`` file or a variable is missing,
        not a finite vector, or of another length than its partner.

    Examples
    --------
    >>> from skhybrid.datasets import load_coupled_electric_drives
    >>> data = load_coupled_electric_drives("path/to/shared/data")  # doctest: +SKIP
    >>> data.splits["test_1"].y.shape  # doctest: +SKIP
    (100, 1)
    """
    file = _find_file(
        path, "coupled_electric_drives", "DATAUNIF.MAT", "load_coupled_electric_drives"
    )
    mat = _MatFile(file, "load_coupled_electric_drives")
    n_init, n_train = 10, 400
    splits = {}
    for i in (1, 2):
        u, y = mat.record(f"u1{i}", f"z1{i}", n_train + n_init)
        splits[f"train_{i}"] = _split(u, y, slice(None, n_train))
        splits[f"test_{i}"] = _split(u, y, slice(n_train, None))
    return Bunch(
        splits=splits,
        n_init=n_init,
        dt=0.02,
        input_names=["voltage"],
        output_names=["pulley_speed"],
        DESCR=_CED_DESCR,
    )


_WH_DESCR = """\
Wiener-Hammerstein benchmark, SYSID 2009 (measured electronic circuit)
-----------------------------------------------------------------------

A static diode-based nonlinearity between two linear filters (nominal order
6). uBenchMark and yBenchMark (V), 188000 samples at fs = 51200 Hz. The
official split (nonlinear-benchmarks v1.0.1) trains on [5200:105200] and tests
on [105200:184000] with n_init = 50; report the RMSE in mV. (The original 2009
protocol estimates on samples 1-100000 and scores 101001-188000, 1-based: the
figures are not interchangeable.)

Cite: J. Schoukens, J. Suykens, L. Ljung, "Wiener-Hammerstein benchmark", 15th
IFAC Symposium on System Identification (SYSID), 2009.
"""


def load_wiener_hammerstein(path):
    """Load the Wiener-Hammerstein benchmark of SYSID 2009.

    Parameters
    ----------
    path : str or pathlib.Path
        Folder holding ``WienerHammerBenchMark.mat``, or its parent holding
        ``wiener_hammerstein/``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        splits : dict of str to Bunch
            ``"train"`` (samples ``[5200:105200]``) and ``"test"``
            (``[105200:184000]``), a Bunch of ``u`` and ``y`` each.
        n_init : int
            Samples at the start of the test split that may initialise a model's
            state (50).
        dt : float
            Sample period (s), ``1 / fs``.
        input_names, output_names : list of str
            ``["u"]`` and ``["y"]``.
        DESCR : str
            Description, splits and citation.

    Raises
    ------
    FileNotFoundError
        When the file is in neither ``path`` nor its subfolder.
    ValueError
        When the file is not a readable ``.mat`` file, a variable is missing,
        not a finite vector or too short for the official split, or ``fs`` is
        not positive.

    Examples
    --------
    >>> from skhybrid.datasets import load_wiener_hammerstein
    >>> data = load_wiener_hammerstein("path/to/shared/data")  # doctest: +SKIP
    >>> data.splits["train"].u.shape  # doctest: +SKIP
    (100000, 1)
    """
    file = _find_file(
        path,
        "wiener_hammerstein",
        "WienerHammerBenchMark.mat",
        "load_wiener_hammerstein",
    )
    mat = _MatFile(file, "load_wiener_hammerstein")
    u, y = mat.record("uBenchMark", "yBenchMark", 184000 - 1)
    fs = mat.scalar("fs", positive=True, what="sample rate (Hz)")
    return Bunch(
        splits={
            "train": _split(u, y, slice(5200, 105200)),
            "test": _split(u, y, slice(105200, 184000)),
        },
        n_init=50,
        dt=1.0 / fs,
        input_names=["u"],
        output_names=["y"],
        DESCR=_WH_DESCR,
    )


_FRICTION_DAMPER_DESCR = """\
Friction damper with backlash (measured)
----------------------------------------

A banded rotary friction device (BRFD), a semi-active friction damper, driven
in displacement by two actuators (dataset 2 of the source, April 2023 tests,
30 lb band tension). Inputs: displacement x (in) and velocity v (in/s); output:
the friction force F (kip), which shows hysteresis, stick-slip and backlash
dead bands. Each file is one test: an N x 6 matrix of columns t (s), x (in),
F (kip), v (in/s), actuator force 1 (lb) and actuator force 2 (lb), sampled at
1024 Hz. Seven harmonic characterisation tests (sinusoidal displacement of 0.5,
1 or 1.5 in at 0.5, 1 or 2 Hz; 3585 to 14337 samples) are the training splits
``train_<file>``, and two predefined earthquake displacements (Kocaeli and
Imperial Valley at the DBE level; 27342 and 28698 samples) the test splits
``test_<file>``, as the companion paper's reproduction folder groups them. The
data set has no official split nor protocol: n_init = 50 samples (about 49 ms)
is our choice of the window that may initialise a model's state.

Source: github.com/ARTS-Laboratory/Dataset-Friction-Damper-with-Backlash at
commit 0e09aa9d950760277e31c08cd93fd01f39a5af09, data/dataset-2/.

Cite: D. Coble, P. Huggins, L. Cao, J. Ricles, A. Downey,
"Dataset-Friction-Damper-with-Backlash", GitHub, 2022. Device: A. Downey, L.
Cao, S. Laflamme, D. Taylor, J. Ricles, "High capacity variable friction damper
based on band brake technology", Engineering Structures 113:287-298, 2016.

License: CC BY-SA 4.0 (Creative Commons Attribution-ShareAlike 4.0
International), http://creativecommons.org/licenses/by-sa/4.0/.
"""

_FRICTION_DAMPER_CITATION = (
    "D. Coble, P. Huggins, L. Cao, J. Ricles, A. Downey, "
    '"Dataset-Friction-Damper-with-Backlash", GitHub, 2022, '
    "https://github.com/ARTS-Laboratory/Dataset-Friction-Damper-with-Backlash."
)
_FRICTION_DAMPER_LICENSE = "CC BY-SA 4.0"

#: The files the friction-damper loader reads, relative to its folder: the
#: harmonic (training) tests, then the earthquake (test) profiles.
_FRICTION_DAMPER_FILES = (
    *(
        f"characterization_datasets/{stem}.json"
        for stem in (
            "0.5Hz30lbtension0.5amplitude",
            "0.5Hz30lbtension1.5amplitude",
            "0.5Hz30lbtension1amplitude",
            "1Hz30lbtension0.5amplitude",
            "1Hz30lbtension1.5amplitude",
            "1Hz30lbtension1amplitude",
            "2Hz30lbtension0.5amplitude",
        )
    ),
    "earthquake_profiles/ImperialValleyDBE.json",
    "earthquake_profiles/KocaeliDBE.json",
)


def _friction_damper_record(file, dt, n_init):
    """The N x 6 matrix of one friction-damper file, checked."""

    def fail(problem):
        raise ValueError(f"load_friction_damper: {file}: {problem}.")

    try:
        with open(file, encoding="utf-8") as handle:
            content = json.load(handle)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        fail(
            f"is not a readable JSON file ({type(exc).__name__}: {exc}); it may be "
            f"truncated, empty or of another format. Replace it with the data "
            f"set's original file"
        )
    if not isinstance(content, dict) or "data" not in content:
        got = sorted(content) if isinstance(content, dict) else type(content).__name__
        fail(f'must hold an object with a "data" matrix; got {got}')
    try:
        matrix = np.asarray(content["data"])
    except ValueError as exc:  # ragged rows
        fail(f'"data" must be an N x 6 numeric matrix; got ragged rows ({exc})')
    if matrix.dtype.kind not in "iuf":
        fail(
            f'"data" must be an N x 6 numeric matrix; got entries of type '
            f"{matrix.dtype} (a non-number or null value)"
        )
    if matrix.ndim != 2 or matrix.shape[1] != 6:
        fail(
            f'"data" must be an N x 6 numeric matrix (t, x, F, v, actuator '
            f"forces 1 and 2); got shape {matrix.shape}"
        )
    matrix = matrix.astype(float)
    bad = np.argwhere(~np.isfinite(matrix))
    if bad.size:
        row, col = bad[0]
        fail(
            f'"data" must hold finite values; got data[{row}][{col}]='
            f"{float(matrix[row, col])!r} ({len(bad)} non-finite of {matrix.size})"
        )
    _check_record_length(matrix.shape[0], n_init, f"load_friction_damper: {file}")
    steps = np.diff(matrix[:, 0])
    off = np.flatnonzero(np.abs(steps - dt) > 1e-6 * dt)
    if off.size:
        k = int(off[0])
        fail(
            f"the time column must advance by dt = 1/1024 s at every sample; got "
            f"t[{k + 1}] - t[{k}] = {float(steps[k]):.9g} s ({off.size} uneven "
            f"steps of {steps.size})"
        )
    return matrix


def load_friction_damper(path):
    """Load the friction damper with backlash (a banded rotary friction device).

    Measured data of a semi-active friction damper driven in displacement:
    inputs displacement and velocity, output the friction force, with
    hysteresis, stick-slip and backlash. The seven harmonic characterisation
    tests at 30 lb band tension are the training splits and the two earthquake
    profiles at the DBE level the test splits. The data are licensed under
    CC BY-SA 4.0 (Creative Commons Attribution-ShareAlike 4.0 International):
    cite D. Coble, P. Huggins, L. Cao, J. Ricles, A. Downey,
    "Dataset-Friction-Damper-with-Backlash", GitHub, 2022
    (github.com/ARTS-Laboratory/Dataset-Friction-Damper-with-Backlash).

    Parameters
    ----------
    path : str or pathlib.Path
        Folder holding the subfolders ``characterization_datasets/`` and
        ``earthquake_profiles/`` (the files of the source's ``data/dataset-2/``,
        with ``_`` for the spaces of the folder names), or its parent holding
        ``friction_damper_backlash/``.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        splits : dict of str to Bunch
            One per file, named after it without ``.json``: the harmonic tests
            ``"train_0.5Hz30lbtension0.5amplitude"``, ...,
            ``"train_2Hz30lbtension0.5amplitude"`` (sorted by name), then the
            earthquake profiles ``"test_ImperialValleyDBE"`` and
            ``"test_KocaeliDBE"``. Each is a Bunch of ``u`` of shape
            (n_times, 2), the columns displacement x (in) and velocity v (in/s),
            and ``y`` of shape (n_times, 1), the friction force F (kip).
        n_init : int
            Samples at the start of a test split that may initialise a model's
            state (50, about 49 ms). The data set has no official protocol; this
            window is our choice.
        dt : float
            Sample period (s), ``1 / 1024``.
        input_names, output_names : list of str
            ``["displacement [in]", "velocity [in/s]"]`` and
            ``["friction force [kip]"]``.
        citation : str
            What to cite when using the data.
        license : str
            ``"CC BY-SA 4.0"``.
        DESCR : str
            Description, splits, source, citation and license.

    Raises
    ------
    FileNotFoundError
        When a file is in neither ``path`` nor its ``friction_damper_backlash/``
        subfolder; the message names the file and the folder.
    ValueError
        When a file is not readable JSON, its ``"data"`` is not an N x 6 numeric
        matrix, holds a NaN or infinite value, is shorter than ``n_init + 1``
        samples, or its time column does not advance by 1/1024 s at every sample
        (to 1e-6 relative); the message names the file and the problem.

    See Also
    --------
    load_emps : Another measured system with dry friction.

    Examples
    --------
    >>> from skhybrid.datasets import load_friction_damper
    >>> data = load_friction_damper("path/to/shared/data")  # doctest: +SKIP
    >>> data.splits["test_KocaeliDBE"].u.shape  # doctest: +SKIP
    (27342, 2)
    """
    dt, n_init = 1.0 / 1024, 50
    splits = {}
    for name in _FRICTION_DAMPER_FILES:
        file = _find_file(
            path, "friction_damper_backlash", name, "load_friction_damper"
        )
        matrix = _friction_damper_record(file, dt, n_init)
        role = "train" if name.startswith("characterization") else "test"
        splits[f"{role}_{Path(name).stem}"] = Bunch(
            u=matrix[:, [1, 3]].copy(), y=matrix[:, [2]].copy()
        )
    order = sorted(splits, key=lambda key: (not key.startswith("train_"), key))
    return Bunch(
        splits={key: splits[key] for key in order},
        n_init=n_init,
        dt=dt,
        input_names=["displacement [in]", "velocity [in/s]"],
        output_names=["friction force [kip]"],
        citation=_FRICTION_DAMPER_CITATION,
        license=_FRICTION_DAMPER_LICENSE,
        DESCR=_FRICTION_DAMPER_DESCR,
    )
