"""Eager against compiled epochs of the state-space hybrid on the CPU, interleaved.

``StateSpaceHybridRegressor(compile_rollout="step")`` trains through
``torch.compile`` of one sample's step, ``"whole"`` through that of the whole
module; ``"auto"`` (the default) compiles the step where the training is long.
This script measures them on the CPU: the missing-physics
suite's hardening spring (``make_missing_physics("hardening-spring",
n_records=3, n_samples=2000, random_state=0)``, the hybrid at its defaults,
``random_state=0``), its joint training's module and packed sub-sequences
captured from a one-epoch fit, then trained by engine nets, one eager, one
with its step compiled and, with ``--whole``, one with the whole module
compiled:

1. each net's first training (one epoch, the starting model's validation
   included): a compiled one pays its compilation there;
2. then one epoch of each in turn (``partial_fit``), ``ROUNDS`` times, so that
   the load of the machine falls on all alike; the median epoch of each and
   the median ratio of the interleaved epochs to the eager one's.

One thread (``torch.set_num_threads(1)``). ``benchmarks/bench_gpu_epoch.py``
is the GPU's measurement.

Run: ``python benchmarks/bench_compile_rollout.py [ROUNDS] [--whole]`` (ROUNDS
defaults to 10; the whole module's compilation takes many minutes).
"""

import copy
import sys
import time
import warnings

import numpy as np
import torch

# The GPU's measurement, beside this script, records the joint training.
from bench_gpu_epoch import joint_training

import skhybrid.hybrid._state_space as state_space
from skhybrid.datasets import make_missing_physics
from skhybrid.hybrid import StateSpaceHybridRegressor


def capture(data):
    """A one-epoch fit; the joint training's estimator, module and data."""
    with joint_training() as seen:
        model = StateSpaceHybridRegressor(
            data.physics, n_init=data.n_init, random_state=0, max_epochs=1
        ).fit_simulation(data.inputs, data.outputs)
    return model, seen


def main():
    args = [a for a in sys.argv[1:] if a != "--whole"]
    rounds = int(args[0]) if args else 10
    kinds = ["eager", "step"] + (["whole"] if "--whole" in sys.argv else [])
    warnings.simplefilter("ignore")
    torch.set_num_threads(1)
    data = make_missing_physics(
        "hardening-spring", n_records=3, n_samples=2000, random_state=0
    )
    model, seen = capture(data)
    est = copy.copy(model).set_params(patience=None, max_epochs=1)
    nets = {}
    for name in kinds:
        compile_kwargs = {} if name == "whole" else None
        kwargs = dict(seen["kwargs"], compile_kwargs=compile_kwargs)
        valid = kwargs.pop("valid")
        module = copy.deepcopy(seen["module"])
        if name == "step":
            module.compile_step({})
        start = time.perf_counter()
        net = state_space.train_module(
            est, lambda m=module: m, seen["X"], seen["y"], valid=valid, **kwargs
        )
        print(
            f"{name}: first training (1 epoch, starting model's validation "
            f"included) {time.perf_counter() - start:.1f} s",
            flush=True,
        )
        # Go on training (the engine drops its compiled module at the end).
        net.compile_kwargs = compile_kwargs
        dict(net.callbacks_)["early_stopping"].patience = 10**9
        nets[name] = net
    print(
        f"{len(seen['X'])} sub-sequences, batch {model.batch_size}, horizon "
        f"{model.horizon}",
        flush=True,
    )
    durations = {name: [] for name in nets}
    for r in range(rounds):
        for name, net in nets.items():
            start = time.perf_counter()
            net.partial_fit(seen["X"], seen["y"], epochs=1)
            durations[name].append(time.perf_counter() - start)
        print(
            f"round {r}: "
            + ", ".join(f"{name} {d[-1]:.3f} s" for name, d in durations.items()),
            flush=True,
        )
    eager = np.array(durations["eager"])
    for name in kinds[1:]:
        ratio = np.array(durations[name]) / eager
        print(
            f"median epoch: eager {np.median(eager):.3f} s, {name} "
            f"{np.median(durations[name]):.3f} s, median ratio {name}/eager "
            f"{np.median(ratio):.3f} (range {ratio.min():.3f}-{ratio.max():.3f})"
        )


if __name__ == "__main__":
    main()
