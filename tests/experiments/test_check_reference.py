"""The reference check runs each benchmark on its recorded CPU kernels."""

import json


def test_every_reference_names_the_kernels_it_was_recorded_with(benchmark_script):
    check = benchmark_script("check_measured_reference.py")
    assert set(check.KERNELS) == set(check.REFERENCE)
    for kernels in check.KERNELS.values():
        assert set(kernels) == {"ATEN_CPU_CAPABILITY", "OPENBLAS_CORETYPE"}


def test_the_run_gets_the_kernels_and_a_finished_run_is_reused(
    benchmark_script, monkeypatch, tmp_path
):
    check = benchmark_script("check_measured_reference.py")
    calls = []
    monkeypatch.setattr(
        check.subprocess, "run", lambda argv, **kw: calls.append((argv, kw["env"]))
    )
    kernels = {"ATEN_CPU_CAPABILITY": "avx2", "OPENBLAS_CORETYPE": "Zen"}
    check.run("emps", "data", tmp_path, kernels)
    ((argv, env),) = calls
    assert argv[4:6] == ["emps", "--data"]
    assert env["ATEN_CPU_CAPABILITY"] == "avx2" and env["OPENBLAS_CORETYPE"] == "Zen"
    (tmp_path / "emps").mkdir()
    (tmp_path / "emps" / "run.json").write_text(json.dumps({"status": "complete"}))
    check.run("emps", "data", tmp_path, kernels)
    assert len(calls) == 1
