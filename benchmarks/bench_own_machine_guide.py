"""How long the own-machine guide's example takes, run as the guide runs it.

The guide (``docs/own_machine.md``) builds a spec from its ``python`` blocks (a
mass on a stiffening spring with friction, records of 800 and 500 samples, a
test record of 600) and runs it with ``run_system``. This script runs those
blocks as they stand in the guide (so the figure follows the guide), then times
the two runs the guide shows: the quick one at one seed and the full one at
seeds 0, 1 and 2. It prints the wall time and the CPU time of each, and the
longest silence between two progress lines of the full run (the guide promises
none over 15 s).

The example is simulated; no benchmark's test record is read.

Usage::

    python benchmarks/bench_own_machine_guide.py [--n-jobs N] [--skip-full]
"""

import argparse
import contextlib
import io
import re
import resource
import sys
import tempfile
import time
from itertools import pairwise
from pathlib import Path

from skhybrid.experiments import run_system

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "own_machine.md"


def guide_spec():
    """Run the guide's ``python`` blocks and return the ``spec`` they build.

    They run in this script's ``__main__``, as in the user's script the guide
    describes (its functions are then stored with the fitted models).
    """
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.DOTALL)
    namespace = vars(sys.modules["__main__"])
    with contextlib.redirect_stdout(io.StringIO()):
        for i, block in enumerate(blocks):
            exec(compile(block, f"own_machine.md block {i + 1}", "exec"), namespace)  # noqa: S102
    return namespace["spec"]


class _Stamps(io.TextIOBase):
    """A stderr that notes when each progress line arrives."""

    def __init__(self, stream):
        self.stream, self.times, self._start = stream, [], time.perf_counter()

    def write(self, text):
        if text.strip():
            self.times.append(time.perf_counter() - self._start)
        return self.stream.write(text)

    def flush(self):
        self.stream.flush()


def _cpu_seconds():
    usage = [
        resource.getrusage(who)
        for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    ]
    return sum(u.ru_utime + u.ru_stime for u in usage)


def timed_run(spec, out, **kwargs):
    """Run ``spec`` into ``out``; return (wall s, CPU s, longest silence s)."""
    stamps = _Stamps(sys.stderr)
    cpu, wall = _cpu_seconds(), time.perf_counter()
    with contextlib.redirect_stderr(stamps):
        run_system(spec, out, **kwargs)
    wall = time.perf_counter() - wall
    edges = [0.0, *stamps.times, wall]
    gaps = [b - a for a, b in pairwise(edges)]
    return wall, _cpu_seconds() - cpu, max(gaps)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-jobs", type=int, default=None)
    parser.add_argument("--skip-full", action="store_true")
    args = parser.parse_args(argv)
    jobs = {} if args.n_jobs is None else {"n_jobs": args.n_jobs}
    spec = guide_spec()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        runs = [("quick, seed 0", {"quick": True, "seeds": (0,)})]
        if not args.skip_full:
            runs.append(("full, seeds 0 1 2", {"seeds": (0, 1, 2)}))
        for label, kwargs in runs:
            out = Path(folder) / label.split(",")[0]
            rows.append((label, *timed_run(spec, out, **jobs, **kwargs)))
    print("\nthe own-machine guide's example (records 800 + 500 samples)")
    print(f"{'run':<20} {'wall':>9} {'CPU':>9} {'longest silence':>16}")
    for label, wall, cpu, gap in rows:
        print(f"{label:<20} {wall:>8.0f}s {cpu:>8.0f}s {gap:>15.1f}s")


if __name__ == "__main__":
    main()
