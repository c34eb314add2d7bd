"""The reference check reruns the selection only, never reading a test record."""

import json


def test_every_benchmark_has_the_kernels_of_its_record(benchmark_script):
    check = benchmark_script("check_measured_reference.py")
    assert set(check.REFERENCE) <= set(check.KERNELS)
    for kernels in check.KERNELS.values():
        assert set(kernels) == {"ATEN_CPU_CAPABILITY", "OPENBLAS_CORETYPE"}


def test_the_run_is_selection_only_with_the_kernels_and_reused_when_finished(
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
    # The spec's tests are dropped before the run: no test record is read.
    assert "tests=None" in argv[2] and argv[3:5] == ["emps", "data"]
    assert env["ATEN_CPU_CAPABILITY"] == "avx2" and env["OPENBLAS_CORETYPE"] == "Zen"
    (tmp_path / "emps").mkdir()
    (tmp_path / "emps" / "run.json").write_text(json.dumps({"status": "complete"}))
    check.run("emps", "data", tmp_path, kernels)
    assert len(calls) == 1


def test_it_compares_the_choice_the_cv_figures_and_the_seal(benchmark_script):
    check = benchmark_script("check_measured_reference.py")
    record = {
        "chosen": {"0": "physics", "1": "physics"},
        "cv_rmse": {"0": 1.00, "1": 1.10},
        "choices_sha256": "a" * 64,
    }
    lines, failed = check.compare(
        "emps",
        record,
        {"0": "physics", "1": "physics"},
        {"0": 1.02, "1": 1.1},
        "a" * 64,
    )
    assert failed == 0 and len(lines) == 3
    lines, failed = check.compare(
        "emps", record, {"0": "physics", "1": "ARX"}, {"0": 1.3, "1": 1.1}, "b" * 64
    )
    assert failed == 3  # the choice, seed 0's CV figure and the seal
    # With the machine's own kernels the seal is not compared.
    assert (
        check.compare(
            "emps", record, record["chosen"], record["cv_rmse"], "b" * 64, native=True
        )[1]
        == 0
    )


def test_a_benchmark_without_a_record_says_so(benchmark_script, capsys, monkeypatch):
    check = benchmark_script("check_measured_reference.py")
    monkeypatch.setattr(check, "REFERENCE", {})
    assert check.main(["--data", "anywhere", "--only", "emps"]) == 0
    assert "emps: no release run recorded yet" in capsys.readouterr().out


def test_the_choices_hash_leaves_out_the_provenance_only(benchmark_script, tmp_path):
    # A later commit changes the seal (it hashes the commit and the kernels),
    # not the choices the check compares.
    check = benchmark_script("check_measured_reference.py")
    selection = {"system": {"name": "emps"}, "seeds": [{"chosen_model": "physics"}]}
    hashes = []
    for commit, chosen in (("aaa", "physics"), ("bbb", "physics"), ("aaa", "ARX")):
        out = tmp_path / f"{commit}-{chosen}"
        out.mkdir()
        sealed = dict(selection, provenance={"commit": commit})
        sealed["seeds"] = [{"chosen_model": chosen}]
        (out / "selection.json").write_text(json.dumps({"selection": sealed}))
        hashes.append(check.choices_sha256(out))
    assert hashes[0] == hashes[1] != hashes[2]


def test_every_record_has_three_seeds_and_a_choices_hash(benchmark_script):
    check = benchmark_script("check_measured_reference.py")
    for system, record in check.REFERENCE.items():
        assert set(record["chosen"]) == set(record["cv_rmse"]) == {"0", "1", "2"}
        assert len(record["choices_sha256"]) == 64, system


def test_a_record_without_the_stack_compares_the_family_without_it(
    benchmark_script, tmp_path
):
    # A run whose stack won: the check of a record made before the family had
    # a stack hashes and chooses among the other models, as that run did.
    check = benchmark_script("check_measured_reference.py")

    def write(out, with_stack):
        out.mkdir()
        validation = {"physics": 1.0, "ARX": 2.0}
        models = {"physics": {"n": 1}, "ARX": {"n": 2}}
        chosen = "physics"
        if with_stack:
            validation["stacked"], models["stacked"] = 0.5, {"weights": {}}
            chosen = "stacked"
        seed = {"models": models, "validation_rmse": validation, "chosen_model": chosen}
        sealed = {"system": {"name": "emps"}, "seeds": [seed], "provenance": {}}
        (out / "selection.json").write_text(json.dumps({"selection": sealed}))
        cv = {m: {"mean": v} for m, v in validation.items()}
        results = {
            "chosen_model": {"0": chosen},
            "cv_rmse": {"0": cv},
            "stack_weights": {"physics": 0.7, "ARX": 0.3} if with_stack else {},
        }
        (out / "results.json").write_text(json.dumps({"systems": {"emps": results}}))

    write(before := tmp_path / "before", with_stack=False)
    write(after := tmp_path / "after", with_stack=True)
    assert check.selection(after, "emps", record_stack=False) == check.selection(
        before, "emps", record_stack=False
    )
    assert check.selection(after, "emps", record_stack=False)[0] == {"0": "physics"}
    assert check.selection(after, "emps")[0] == {"0": "stacked"}
    assert check.choices_sha256(after) != check.choices_sha256(before)
    (line,) = check.stack_lines(after, "emps")
    assert "stack CV RMSE 0.5 (chosen; weights physics 0.7, ARX 0.3)" in line
    assert check.stack_lines(before, "emps") == []
