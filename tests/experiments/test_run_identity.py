"""One run, one identity: a built-in benchmark started either documented way.

``skhybrid run NAME --data DIR`` and ``run_system(benchmark_spec(NAME, DIR),
out)`` must give the run folder the same identity (``run.json``), so that one
resumes what the other began. Nothing is fitted: the run stops as it starts, and
only the estimation records are read.
"""

import pytest

from skhybrid.benchmarks import benchmark_spec
from skhybrid.cli import main
from skhybrid.experiments import RunTransaction, run_measured, run_system


class _Stop(Exception):
    """Raised where the run would start: its plan has been seen."""


@pytest.fixture
def plans(monkeypatch):
    """The plans runs are started with (each run stops there)."""
    seen = []

    def start(self, plan, command, **kwargs):
        seen.append(plan)
        raise _Stop

    monkeypatch.setattr(RunTransaction, "start", start)
    return seen


@pytest.mark.parametrize("quick", [False, True])
def test_a_benchmark_has_one_identity_from_the_shell_and_from_python(
    shared_data_dir, tmp_path, plans, quick
):
    argv = ["run", "emps", "--data", str(shared_data_dir), "--out"]
    argv += [str(tmp_path / "cli"), "--no-progress"] + ["--quick"] * quick
    with pytest.raises(_Stop):
        main(argv)
    spec = benchmark_spec("emps", shared_data_dir, quick=quick)
    with pytest.raises(_Stop):
        run_system(spec, tmp_path / "spec", quick=quick)
    with pytest.raises(_Stop):
        run_measured("emps", shared_data_dir, tmp_path / "name", quick=quick)
    cli, python, by_name = (plan.identity for plan in plans)
    assert cli == python == by_name
    assert cli["systems"] == ["emps"] and cli["quick"] is quick
    assert len(cli["spec"]) == 64  # the spec's digest, not a module's name
    # Nothing of a run stays in a folder the run did not start in.
    assert not any((tmp_path / name).exists() for name in ("cli", "spec", "name"))


def test_another_spec_is_another_run(shared_data_dir, tmp_path, plans):
    from dataclasses import replace

    spec = benchmark_spec("emps", shared_data_dir)
    for changed in (spec, replace(spec, segments=(2000,))):
        with pytest.raises(_Stop):
            run_system(changed, tmp_path / "run")
    same, other = (plan.identity for plan in plans)
    assert same["spec"] != other["spec"]
