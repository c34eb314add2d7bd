"""`skhybrid --help`, `list` and `--version` answer without importing torch.

The command line goes through :mod:`skhybrid.experiments`' public names only.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import skhybrid
from skhybrid.cli import main
from skhybrid.experiments._catalog import CATALOG, DATA_FILES


@pytest.mark.parametrize("argv", [["--help"], ["list"], ["--version"]])
def test_light_commands_import_no_torch(argv):
    code = (
        "import sys\n"
        "from skhybrid.cli import main\n"
        "try:\n"
        f"    main({argv!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        "heavy = sorted(m for m in ('torch', 'skorch') if m in sys.modules)\n"
        "print('HEAVY', heavy)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert "HEAVY []" in out


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"skhybrid {skhybrid.__version__}"


def test_the_catalog_says_what_the_systems_say():
    from skhybrid import experiments

    assert list(CATALOG) == [*experiments.SYSTEMS, *experiments.MEASURED_SYSTEMS]
    for name, system in experiments.SYSTEMS.items():
        kind, title, shows = CATALOG[name]
        assert (kind, title) == ("simulated", system.title)
        splits = ", ".join(system.split_descriptions())
        assert shows == f"section {system.section}; {splits}"
    for name, system in experiments.MEASURED_SYSTEMS.items():
        kind, title, _ = CATALOG[name]
        assert (kind, title) == ("measured", system.title)
        assert name in DATA_FILES


def test_list_shows_every_system_with_its_kind_and_data(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SKHYBRID_DATA", str(tmp_path / "home"))
    (tmp_path / "data" / "emps").mkdir(parents=True)
    for name in DATA_FILES["emps"][1]:
        (tmp_path / "data" / "emps" / name).write_bytes(b"")
    assert main(["list", "--data", str(tmp_path / "data")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == list(CATALOG)
    kinds = {line.split()[0]: line.split()[1] for line in lines}
    assert kinds == {name: kind for name, (kind, _, _) in CATALOG.items()}
    by_name = {line.split()[0]: line for line in lines}
    assert f"data present in {tmp_path / 'data' / 'emps'}" in by_name["emps"]
    assert "data missing in" in by_name["silverbox"]
    assert main(["list"]) == 0  # the data home: nothing fetched there yet
    assert "data not yet fetched" in capsys.readouterr().out


def test_claims_are_judged_on_full_settings_only(monkeypatch):
    from types import SimpleNamespace

    from skhybrid.experiments import RunSettings
    from skhybrid.experiments.one_step import _claims

    def one_claim(result):
        return [{"claim": "c", "passed": False, "detail": "x = 2"}]

    system = SimpleNamespace(name="pendulum", claims=one_claim)
    full = SimpleNamespace(system=system, settings=RunSettings(seed=3))
    quick = SimpleNamespace(system=system, settings=RunSettings(quick=True))
    assert _claims.check_claims(full)[0]["passed"] is False
    claim = _claims.check_claims(quick)[0]
    assert claim["passed"] is None
    assert claim["detail"] == "not evaluated on quick settings; x = 2"


def test_list_into_a_pipe_closed_early_ends_quietly():
    # ``skhybrid list | head -1``: the reader goes before the list is written.
    proc = subprocess.Popen(
        [sys.executable, "-m", "skhybrid.cli", "list"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    proc.stdout.close()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0
    assert "Traceback" not in err and "BrokenPipe" not in err


def test_the_command_line_imports_nothing_private_of_experiments():
    import skhybrid.cli
    from skhybrid import experiments

    tree = ast.parse(Path(skhybrid.cli.__file__).read_text())
    imported = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module is not None:
            imported += [(node.module, alias.name) for alias in node.names]
        elif isinstance(node, ast.Import):
            imported += [(alias.name, None) for alias in node.names]
    from_experiments = [
        (module, name) for module, name in imported if "experiments" in module
    ]
    assert from_experiments, "the walker must see the command line's imports"
    for module, name in from_experiments:
        assert module == "skhybrid.experiments", module
        assert name in experiments.__all__, name
