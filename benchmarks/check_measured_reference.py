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
is reported as such (``REFERENCE`` lists what has been recorded).

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

#: The release runs' record (docs/results.md): system -> chosen models at seeds
#: 0, 1, 2, each seed's CV RMSE of its chosen model (official units), the hash
#: of the choices (the sealed selection without its provenance) and the seal's
#: SHA-256 itself. From the release run of 2026-11-27 at commit 5454653
#: (benchmarks/LOG.md); a benchmark whose release run is still to come is absent.
REFERENCE = {
    "cascaded-tanks": {
        "chosen": {
            "0": "state-space hybrid",
            "1": "state-space hybrid",
            "2": "state-space hybrid",
        },
        "cv_rmse": {
            "0": 0.26319712270069084,
            "1": 0.26319712270069084,
            "2": 0.26319712270069084,
        },
        "choices_sha256": "2bb998b7dfedba04b5e3a39186963cd1b0243997f272cbfd42f111503e265305",  # noqa: E501
        "selection_sha256": "90cca4fd0ffe8b9f52e87ecbe58f1b9e4c2f9805e3df9f909b6713577b64d822",  # noqa: E501
    },
    "friction-damper": {
        "chosen": {
            "0": "physics + dense ensemble",
            "1": "physics + dense ensemble",
            "2": "physics + dense ensemble",
        },
        "cv_rmse": {
            "0": 0.351815668007194,
            "1": 0.351815668007194,
            "2": 0.351815668007194,
        },
        "choices_sha256": "29e734f7503268613033a77fc7b39e9f2f04c13ecb470846a31a8882a25c7513",  # noqa: E501
        "selection_sha256": "290d8ba50853de854a2b52a5ed3f8f2f8da01501d14c6a389d99d2d060890a1e",  # noqa: E501
    },
    "coupled-electric-drives": {
        "chosen": {
            "0": "state-space hybrid",
            "1": "state-space hybrid",
            "2": "state-space hybrid",
        },
        "cv_rmse": {
            "0": 0.16541461967836316,
            "1": 0.16541461967836316,
            "2": 0.16541461967836316,
        },
        "choices_sha256": "0d9e228eaf446aa64b8338a5a8ae96f797430442f85c7196b21c858d98104789",  # noqa: E501
        "selection_sha256": "3f5864f048bcbabbbe08a5b252c2b9f0bf97cf9e08cf291f4a91d5d262a9c528",  # noqa: E501
    },
    "emps": {
        "chosen": {"0": "physics", "1": "physics", "2": "physics"},
        "cv_rmse": {
            "0": 1.4428454945346316,
            "1": 1.4428454945346316,
            "2": 1.4428454945346316,
        },
        "choices_sha256": "e879b1c53e6f7804088b3a0df360458a89b98577e62fe0a482412a1b2c2082e6",  # noqa: E501
        "selection_sha256": "9047aad7b3f938f9820d2f056cb20fd6538ee39229fb5f41fde52ee3b18af133",  # noqa: E501
    },
    "wiener-hammerstein": {
        "chosen": {
            "0": "physics + linear",
            "1": "physics + linear",
            "2": "physics + linear",
        },
        "cv_rmse": {
            "0": 0.2779793351232822,
            "1": 0.2779793351232822,
            "2": 0.2779793351232822,
        },
        "choices_sha256": "b0926b3cac782caa79343af6babfb1eb133ffaf4c2becabde89a9a8290eab68e",  # noqa: E501
        "selection_sha256": "db8b24a4cf0bdbfe3df473aa0206d568eaea11a5f78757ab194844f4fe1b8bf8",  # noqa: E501
    },
    "silverbox": {
        "chosen": {
            "0": "physics + dense ensemble",
            "1": "physics + dense ensemble",
            "2": "physics + dense ensemble",
        },
        "cv_rmse": {
            "0": 0.20846601249448324,
            "1": 0.20846601249448324,
            "2": 0.20846601249448324,
        },
        "choices_sha256": "1479779e5e3b4222f68ebff809493b5fdb237c3ccc9e6b0ec3145e1ac96e56e2",  # noqa: E501
        "selection_sha256": "4ce0b5e8ccff85f1fa41294e364daea011e41e4b58f5854148c6d663a5169297",  # noqa: E501
    },
}

#: The CPU kernels a release run is recorded with (this project's machine's):
#: torch's AVX-512 and OpenBLAS's SkylakeX.
_AVX512 = {"ATEN_CPU_CAPABILITY": "avx512", "OPENBLAS_CORETYPE": "SkylakeX"}
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


def choices_sha256(out):
    """SHA-256 of the sealed selection in ``out`` without its provenance.

    The seal hashes the commit, the version and the CPU kernels with the
    choices; a later commit that changes no choice changes the seal but not this.
    """
    selection = json.loads((out / "selection.json").read_text())["selection"]
    selection = {k: v for k, v in selection.items() if k != "provenance"}
    text = json.dumps(selection, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def selection(out, system):
    """The chosen models, each seed's CV RMSE of its choice, and their hash."""
    results = json.loads((out / "results.json").read_text())["systems"][system]
    chosen = results["chosen_model"]
    cv = {
        seed: results["cv_rmse"][seed][model]["mean"] for seed, model in chosen.items()
    }
    return chosen, cv, choices_sha256(out)


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
        lines, failed = compare(
            system, REFERENCE[system], *selection(out, system), native=args.native
        )
        print("\n".join(lines))
        failures += failed
    print(
        "every recorded selection reproduced" if not failures else f"{failures} failed"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
