"""The deepSI comparison script: its protocol's split and its message without deepSI."""

import re
import sys

import pytest

SCRIPT = "compare_subnet_coupled_drives.py"


def test_without_deepsi_it_says_how_to_install_it(monkeypatch, benchmark_script):
    monkeypatch.setitem(sys.modules, "deepSI", None)
    with pytest.raises(SystemExit, match=re.escape("pip install deepsi==0.4.4")):
        benchmark_script(SCRIPT).main(["--data", "anywhere"])


def test_it_fits_the_part_the_selection_fits(shared_data_dir, benchmark_script):
    from skhybrid.datasets import load_coupled_electric_drives

    d = load_coupled_electric_drives(shared_data_dir)
    U = [d.splits[k].u for k in ("train_1", "train_2")]
    # Three quarters of each record: what its documented run was fitted on.
    assert [int(0.75 * len(u)) for u in U] == [benchmark_script(SCRIPT).N_FIT] * 2
