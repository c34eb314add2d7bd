"""Rerun the measured benchmarks' selection and compare it with the record.

The release checklist's check that every figure of record in docs/results.md
follows from its documented command, **without looking at a test record**: for
each benchmark it runs the selection only (the built-in spec with
``tests=None``, through :func:`skhybrid.experiments.run_system`; seeds 0, 1, 2:
the cross-validated search at seed 0, its choices refitted at each seed), then
compares

- the models chosen at the seeds,
- each seed's cross-validated RMSE of its chosen model (within 2 %, or within
  the recorded seeds' range widened by half its width), and
- the SHA-256 of the sealed selection without its provenance (the same
  canonical JSON as the seal's, less the commit, version and kernels that a
  later commit changes), which must be identical where the run is
  deterministic under the recorded CPU kernels,

with the release run's record. Test RMSE is never read, so running this check
is not a look at the test records (benchmarks/LOG.md counts the looks).

Each benchmark runs under the CPU kernels its figures were recorded with
(``KERNELS``): torch's (``ATEN_CPU_CAPABILITY``) and OpenBLAS's
(``OPENBLAS_CORETYPE``); networks trained with other kernels round otherwise and
end elsewhere. ``--native`` runs with the machine's own kernels instead (the
figures then agree within the seeds' spread, not to the digit, and the hash
differs).

A benchmark with no release run recorded under the cross-validated search yet
is reported as such (``REFERENCE`` lists what has been recorded). A record made
before the family had its stack is compared with the family without it (the
stack is fitted last and changes no other model's fit or figure); the stack's
own CV RMSE is then printed apart, with whether the run quotes it.

Run: ``python benchmarks/check_measured_reference.py --data ../shared/data``;
``--runs DIR`` keeps the run folders, ``--only SYSTEM`` checks one benchmark.
"""

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

from skhybrid.benchmarks import MEASURED

#: The family's stack, the last model of every measured run.
STACK_MODEL = "stacked"

#: The release runs' record (docs/results.md): system -> chosen models at seeds
#: 0, 1, 2, each seed's CV RMSE of its chosen model (official units), the hash
#: of the choices (the sealed selection without its provenance) and the seal's
#: SHA-256 itself. From the release run of 2026-11-29 at commit 188add5, the
#: family with its stack (``"stack": True``; benchmarks/LOG.md). A record
#: without ``"stack": True`` would be one made before the family had its stack:
#: the check then compares the family without it, chosen by the same rule, and
#: prints the stack's CV RMSE apart, with whether the run quotes it.
REFERENCE = {
    "cascaded-tanks": {
        "chosen": {
            "0": "stacked",
            "1": "stacked",
            "2": "stacked",
        },
        "cv_rmse": {
            "0": 0.2531484556039966,
            "1": 0.2531484556039966,
            "2": 0.2531484556039966,
        },
        "choices_sha256": "9898d581d59c5e4186b0e4cbd96c4f9b686015ea58c329aff79a0500435b711f",  # noqa: E501
        "selection_sha256": "a6215ca1507af85d27b6c0a44f3c68df6faf92cb6510213f32faa4691a24bc57",  # noqa: E501
        "stack": True,
    },
    "friction-damper": {
        "chosen": {
            "0": "physics + dense",
            "1": "physics + dense",
            "2": "physics + dense",
        },
        "cv_rmse": {
            "0": 0.3548556024940649,
            "1": 0.3548556024940649,
            "2": 0.3548556024940649,
        },
        "choices_sha256": "a1cda99d591a2746697206c538776502a40b10305699a0faf5b31d3e2801e2b9",  # noqa: E501
        "selection_sha256": "674f56c8d08ec1b433eedd5bfc0bb20d342db3ff5776e288d32530d9aec77c2c",  # noqa: E501
        "stack": True,
    },
    "coupled-electric-drives": {
        "chosen": {
            "0": "state-space hybrid",
            "1": "state-space hybrid",
            "2": "state-space hybrid",
        },
        "cv_rmse": {
            "0": 0.1645864854572301,
            "1": 0.1645864854572301,
            "2": 0.1645864854572301,
        },
        "choices_sha256": "dcb9fb0e00d0ce39e5aaf068fda2c76ab9a6251c765957e66cb08df2022ba7b2",  # noqa: E501
        "selection_sha256": "ffd1fa851d2ef9c9ae289e9bf16839d69a496b464f90ffa0fbf6fe918ecc95ad",  # noqa: E501
        "stack": True,
    },
    "emps": {
        "chosen": {
            "0": "physics",
            "1": "physics",
            "2": "physics",
        },
        "cv_rmse": {
            "0": 1.4423927222625061,
            "1": 1.4423927222625061,
            "2": 1.4423927222625061,
        },
        "choices_sha256": "8bba1cdb43beb4400261b07db7951be1d10438b50387641ce19f029e3304b99c",  # noqa: E501
        "selection_sha256": "dd77adf5be14fdd4a6b845198bcbd3eb85c5fcff12b2b288839e66a55f526d41",  # noqa: E501
        "stack": True,
    },
    "wiener-hammerstein": {
        "chosen": {
            "0": "physics + linear",
            "1": "physics + linear",
            "2": "physics + linear",
        },
        "cv_rmse": {
            "0": 0.2779283719811644,
            "1": 0.2779283719811644,
            "2": 0.2779283719811644,
        },
        "choices_sha256": "2598ef3feaef6a1ab2210bfff89d3f590113c2f922a47a4969d1ef23c8bb62f3",  # noqa: E501
        "selection_sha256": "fa82af4b53d9fadacf0cbfbfaa50a883b5590dff1ea081b100cfa1e1e598d752",  # noqa: E501
        "stack": True,
    },
    "silverbox": {
        "chosen": {
            "0": "stacked",
            "1": "stacked",
            "2": "stacked",
        },
        "cv_rmse": {
            "0": 0.20561621400309293,
            "1": 0.20561621400309293,
            "2": 0.20561621400309293,
        },
        "choices_sha256": "bde5badd7086145a43cc3c1133aabc79d0fac40932b934c81ef10bc9238b6601",  # noqa: E501
        "selection_sha256": "ee0ec602548af6f4b890fd0c8a7c6169269e7775590cd5b861ca26adc7cf8b07",  # noqa: E501
        "stack": True,
    },
}

#: The CPU kernels a release run is recorded with (this project's machine's):
#: torch's AVX-512 and OpenBLAS's Haswell (the release run of 2026-11-27 had
#: OpenBLAS's SkylakeX).
_AVX512 = {"ATEN_CPU_CAPABILITY": "avx512", "OPENBLAS_CORETYPE": "Haswell"}
KERNELS = dict.fromkeys(MEASURED, _AVX512)

#: The selection-only run, in a fresh interpreter that has the kernels set.
_SELECT = """
import dataclasses, sys
from skhybrid.benchmarks import benchmark_spec
from skhybrid.experiments import run_system
spec = dataclasses.replace(benchmark_spec(sys.argv[1], sys.argv[2]), tests=None)
run_system(spec, sys.argv[3], seeds=[0, 1, 2], n_jobs=2)
"""


def run(system, data, runs, kernels):
    """The selection-only run of ``system`` in ``runs/system`` (reused if done)."""
    out = runs / system
    manifest = out / "run.json"
    if manifest.is_file() and json.loads(manifest.read_text()).get("status") == (
        "complete"
    ):
        return out
    argv = [sys.executable, "-c", _SELECT, system, str(data), str(out)]
    subprocess.run(argv, check=True, env={**os.environ, **kernels})
    return out


def _argmin(validation):
    return min(validation, key=validation.get) if validation else None


def without_stack(selection):
    """A sealed selection as the family without its stack would have sealed it.

    The stack is fitted last, from the other models' out-of-fold runs, and
    changes none of their fits or figures: removing it (and choosing among the
    others by the same rule) gives the selection of the family the record was
    made with.
    """
    seeds = []
    for entry in selection["seeds"]:
        validation = {
            k: v for k, v in entry["validation_rmse"].items() if k != STACK_MODEL
        }
        seeds.append(
            {
                **entry,
                "models": {
                    k: v for k, v in entry["models"].items() if k != STACK_MODEL
                },
                "validation_rmse": validation,
                "chosen_model": _argmin(validation),
            }
        )
    return {**selection, "seeds": seeds}


def choices_sha256(out, record_stack=True):
    """SHA-256 of the sealed selection in ``out`` without its provenance.

    The seal hashes the commit, the version and the CPU kernels with the
    choices; a later commit that changes no choice changes the seal but not this.
    ``record_stack=False`` hashes the family without its stack
    (:func:`without_stack`), as a record made before the stack holds it.
    """
    selection = json.loads((out / "selection.json").read_text())["selection"]
    selection = {k: v for k, v in selection.items() if k != "provenance"}
    if not record_stack:
        selection = without_stack(selection)
    text = json.dumps(selection, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def selection(out, system, record_stack=True):
    """The chosen models, each seed's CV RMSE of its choice, and their hash.

    With ``record_stack=False``, of the family without its stack.
    """
    results = json.loads((out / "results.json").read_text())["systems"][system]
    cv_rmse = {
        seed: {
            model: entry["mean"]
            for model, entry in by_model.items()
            if record_stack or model != STACK_MODEL
        }
        for seed, by_model in results["cv_rmse"].items()
    }
    chosen = results["chosen_model"]
    if not record_stack:  # the same rule, among the models the record had
        chosen = {seed: _argmin(cv_rmse[seed]) for seed in chosen}
    cv = {seed: cv_rmse[seed][model] for seed, model in chosen.items()}
    return chosen, cv, choices_sha256(out, record_stack)


def stack_lines(out, system):
    """The stack's CV RMSE at each seed and whether the run quotes it (no test)."""
    results = json.loads((out / "results.json").read_text())["systems"][system]
    lines = []
    for seed, by_model in results["cv_rmse"].items():
        entry = by_model.get(STACK_MODEL)
        if entry is None:
            continue
        quoted = results["chosen_model"][seed] == STACK_MODEL
        lines.append(
            f"-    {system} seed {seed}: stack CV RMSE {entry['mean']:.4g} "
            f"({'chosen' if quoted else 'not chosen'}; weights "
            + ", ".join(
                f"{m} {w:.3g}" for m, w in results["stack_weights"].items() if w > 0
            )
            + ")"
        )
    return lines


def compare(system, record, chosen, cv, sha256, *, native=False):
    """Lines of the comparison, and how many failed."""
    lines, failures = [], 0
    if chosen != record["chosen"]:
        failures += 1
        lines.append(f"FAIL {system}: chosen {chosen}, recorded {record['chosen']}")
    values = list(record["cv_rmse"].values())
    slack = max((max(values) - min(values)) / 2, 0.02 * max(values))
    for seed, value in cv.items():
        ref = record["cv_rmse"][seed]
        ok = abs(value - ref) <= slack
        failures += not ok
        lines.append(
            f"{'ok  ' if ok else 'FAIL'} {system} seed {seed}: CV RMSE {value:.4g}, "
            f"recorded {ref:.4g}"
        )
    if not native:
        ok = sha256 == record["choices_sha256"]
        failures += not ok
        lines.append(f"{'ok  ' if ok else 'FAIL'} {system}: choices {sha256[:16]}")
    return lines, failures


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the benchmark files")
    parser.add_argument("--runs", default="reference-runs", help="run folders")
    parser.add_argument("--only", choices=sorted(MEASURED), help="one benchmark")
    parser.add_argument(
        "--native", action="store_true", help="the machine's own CPU kernels"
    )
    args = parser.parse_args(argv)
    runs, failures = Path(args.runs), 0
    for system in MEASURED:
        if args.only and system != args.only:
            continue
        if system not in REFERENCE:
            print(f"-    {system}: no release run recorded yet")
            continue
        kernels = {} if args.native else KERNELS[system]
        out = run(system, args.data, runs, kernels)
        record = REFERENCE[system]
        picked = selection(out, system, record.get("stack", False))
        lines, failed = compare(system, record, *picked, native=args.native)
        if not record.get("stack", False):
            lines += stack_lines(out, system)
        print("\n".join(lines))
        failures += failed
    print(
        "every recorded selection reproduced" if not failures else f"{failures} failed"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
