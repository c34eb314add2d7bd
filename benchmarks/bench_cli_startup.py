"""How long `skhybrid --help`, `list` and `--version` take, against bare Python.

Each command runs in a fresh interpreter ``--runs`` times (interleaved with
``python -c pass``, the baseline every command pays); the script prints the
median wall time of each and its ratio to the baseline. Issue 26 asks for under
a second: the command line imports neither torch nor the systems for these.

Run: ``python benchmarks/bench_cli_startup.py``.
"""

import argparse
import statistics
import subprocess
import sys
import time

COMMANDS = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "skhybrid --help": [sys.executable, "-m", "skhybrid", "--help"],
    "skhybrid list": [sys.executable, "-m", "skhybrid", "list"],
    "skhybrid --version": [sys.executable, "-m", "skhybrid", "--version"],
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    times = {name: [] for name in COMMANDS}
    for _ in range(args.runs):
        for name, argv in COMMANDS.items():
            start = time.perf_counter()
            subprocess.run(argv, check=True, capture_output=True)
            times[name].append(time.perf_counter() - start)
    base = statistics.median(times["python -c pass"])
    for name, values in times.items():
        median = statistics.median(values)
        print(f"{name:20s} {median * 1e3:7.0f} ms  ({median / base:.1f}x bare Python)")


if __name__ == "__main__":
    main()
