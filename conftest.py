"""Root pytest configuration: one torch thread per test process.

pytest-xdist runs two workers on CI's two cores; with torch's default of one thread
per core the workers would compete for the cores (measured: up to 12x slower). Set
here, at the root, so that doctests under ``skhybrid/`` get it too.
"""

try:
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover
    pass

# The deprecated alias module warns on import; doctest collection must not import it
# (tests/experiments/test_cli.py checks the alias on purpose).
collect_ignore = ["skhybrid/benchmarks.py"]
