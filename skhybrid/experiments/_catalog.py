"""What ``skhybrid list`` and ``--help`` show, without importing the systems.

The systems themselves (their simulators, physics and zoos) import torch; the
command line lists them from this catalog instead, so that ``skhybrid list``
answers in a fraction of a second. ``tests/experiments/test_cli_startup.py``
checks that the catalog says what the systems say.
"""

import os
from pathlib import Path

__all__ = ["CATALOG", "DATA_FILES", "list_systems"]

#: name -> (kind, title, what the run shows)
CATALOG = {
    "pendulum": (
        "simulated",
        "Inverted pendulum (gymnasium Pendulum-v1)",
        "section 6.1; train, interpolation, extrapolation",
    ),
    "double-pendulum": (
        "simulated",
        "Double pendulum with an unmodelled small pendulum",
        "section 6.2; train, interpolation",
    ),
    "dc-motor": (
        "simulated",
        "DC motor driving a load through a gear with backlash",
        "section 6.3; train, interpolation, extrapolation",
    ),
    "cascaded-tanks": (
        "measured",
        "Cascaded tanks with overflow (measured)",
        "official split; test",
    ),
    "emps": (
        "measured",
        "EMPS electro-mechanical positioning axis (measured, closed loop)",
        "official split; test",
    ),
    "silverbox": (
        "measured",
        "Silverbox electronic Duffing oscillator (measured)",
        (
            "official splits; test_multisine, test_arrow_full, "
            "test_arrow_no_extrapolation"
        ),
    ),
    "coupled-electric-drives": (
        "measured",
        "Coupled electric drives, DATAUNIF (measured)",
        "official split of both records; test_1, test_2",
    ),
    "wiener-hammerstein": (
        "measured",
        "Wiener-Hammerstein electronic circuit, SYSID 2009 (measured)",
        "official split; test",
    ),
    "friction-damper": (
        "measured",
        "Band friction damper with backlash, ARTS-Lab dataset 2 (measured)",
        "harmonic tests estimate; KocaeliDBE, ImperialValleyDBE",
    ),
}

#: measured system -> (subfolder of the data folder, the files its loader reads)
DATA_FILES = {
    "cascaded-tanks": ("cascaded_tanks", ("dataBenchmark.mat",)),
    "emps": ("emps", ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")),
    "silverbox": ("silverbox", ("SNLS80mV.mat",)),
    "coupled-electric-drives": ("coupled_electric_drives", ("DATAUNIF.MAT",)),
    "wiener-hammerstein": ("wiener_hammerstein", ("WienerHammerBenchMark.mat",)),
    "friction-damper": (
        "friction_damper_backlash",
        (
            "characterization_datasets/1Hz30lbtension1amplitude.json",
            "earthquake_profiles/KocaeliDBE.json",
            "earthquake_profiles/ImperialValleyDBE.json",
        ),
    ),
}


def _data_status(name, data):
    """Where a measured system's files are, or that they will be fetched."""
    folder, files = DATA_FILES[name]
    if data is not None:
        places = [Path(data), Path(data) / folder]
    else:
        home = os.environ.get("SKHYBRID_DATA", Path("~") / "skhybrid_data")
        places = [Path(home).expanduser() / folder]
    for place in places:
        if all((place / f).is_file() for f in files):
            return f"data present in {place}"
    if data is not None:
        return f"data missing in {data}"
    return "data not yet fetched (downloaded on the first run)"


def list_systems(data=None):
    """The built-in systems, what each shows and, for a measured one, its files.

    Answers without importing the systems (nor torch): ``skhybrid list`` prints
    it.

    Parameters
    ----------
    data : str or Path or None, default=None
        A folder of measured benchmark files; None looks in the data home
        (``$SKHYBRID_DATA``, else ``~/skhybrid_data``).

    Returns
    -------
    systems : list of tuple
        ``(name, kind, title, shows, data)`` for each system: ``kind`` is
        ``"simulated"`` or ``"measured"``, ``data`` where a measured system's
        files are (or that they are missing or not yet fetched), None for a
        simulated one.

    Examples
    --------
    >>> from skhybrid.experiments import list_systems
    >>> name, kind, title, shows, data = list_systems()[0]
    >>> name, kind, data
    ('pendulum', 'simulated', None)
    """
    return [
        (
            name,
            kind,
            title,
            shows,
            _data_status(name, data) if kind == "measured" else None,
        )
        for name, (kind, title, shows) in CATALOG.items()
    ]
