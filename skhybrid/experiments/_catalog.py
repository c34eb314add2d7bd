"""What ``skhybrid list`` and ``--help`` show, without importing the systems.

The systems themselves (their simulators, physics and zoos) import torch; the
command line lists them from this catalog instead, so that ``skhybrid list``
answers in a fraction of a second. ``tests/experiments/test_cli_startup.py``
checks that the catalog says what the systems say.
"""

__all__ = ["CATALOG", "DATA_FILES"]

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
