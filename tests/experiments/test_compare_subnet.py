"""The deepSI comparison script: its protocol's split and its message without deepSI."""

import importlib.util
import re
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "compare_subnet_coupled_drives.py"


def _script():
    spec = importlib.util.spec_from_file_location("compare_subnet", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_without_deepsi_it_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "deepSI", None)
    with pytest.raises(SystemExit, match=re.escape("pip install deepsi==0.4.4")):
        _script().main(["--data", "anywhere"])


def test_it_fits_the_part_the_selection_fits(shared_data_dir):
    from skhybrid.datasets import load_coupled_electric_drives
    from skhybrid.experiments._measured_zoo import _tail_split

    d = load_coupled_electric_drives(shared_data_dir)
    U = [d.splits[k].u for k in ("train_1", "train_2")]
    (fit_u, _), _ = _tail_split(U, U)
    assert [len(u) for u in fit_u] == [_script().N_FIT] * 2
