"""Seconds per epoch of a Silverbox-sized state-space hybrid: GPU eager, captured, CPU.

Issue 50 measured an epoch of the Silverbox hybrid (horizon 50, a (64, 64)
correction, batch 256) at 6.29 s on an H200 against 2.72 s on 16 CPU threads:
on the GPU an epoch is thousands of tiny kernel launches. This script measures
the joint training's epochs of that hybrid, through the engine
(:func:`skhybrid.neural.engine.train_module`, as ``fit_simulation`` trains),
from the same module and the same packed sub-sequences, as:

1. ``cpu``: on the CPU with all its threads;
2. ``cpu step``: the same, one sample's step compiled (``compile_rollout=
   "step"``, the default's choice for a training this long);
3. ``cuda eager``: on the GPU, uncaptured;
4. ``cuda step``: on the GPU, one sample's step compiled (inductor's fused
   kernels, the loop over the horizon in Python);
5. ``cuda graphs only``: ``torch.compile(backend="cudagraphs")``, the eager
   kernels replayed as CUDA graphs without inductor's code generation (the
   capture that compiles fastest);
6. ``cuda captured``: on the GPU as ``compile_rollout="whole"`` trains
   (``torch.compile`` of the module, ``mode="reduce-overhead"``: inductor's
   kernels replayed as CUDA graphs).

For each: the first epoch (which pays the compilation where there is one),
the median of the others, and the whole training's wall time (the starting
model's validation included). Without CUDA it prints the CPU row and says
that the GPU rows need a GPU.

Data: with ``--data DIR``, the Silverbox estimation record
(``benchmark_spec("silverbox", DIR).estimation_records()``; no test record is
read), cut into six pieces as the benchmark's hybrid trains on it; otherwise
simulated Duffing records of the same size (six of 10,844 samples, a
multisine input). The physics is the benchmark's Duffing model
(:func:`skhybrid.benchmarks.silverbox.physics_from_records`, band-limited
inputs) at its one-step start (its simulation fit is not what is measured),
the hybrid the benchmark's candidate (``hybrid_settings(50, (64, 64),
corrected_states=["derivative (latent)"])``).

Run: ``python benchmarks/bench_gpu_epoch.py [--data DIR] [--epochs 4]
[--samples 10844]``
(sized for a ten-minute slot on one GPU and 16 cores).
"""

import argparse
import contextlib
import copy
import os
import time
import warnings

import numpy as np
import torch

import skhybrid.hybrid._state_space as state_space
from skhybrid.benchmarks.silverbox import physics_from_records
from skhybrid.domain import band_limited_inputs
from skhybrid.experiments import hybrid_settings
from skhybrid.hybrid import StateSpaceHybridRegressor

N_PIECES, PIECE, DT = 6, 10_844, 2**14 / 1e7


def simulated_records(piece=PIECE, seed=0):
    """Six Duffing records of ``piece`` samples (a Silverbox's) under a multisine."""
    from skhybrid.benchmarks.silverbox import duffing
    from skhybrid.domain import StateSpaceModel

    rng = np.random.default_rng(seed)
    t = np.arange(N_PIECES * piece) * DT
    freqs = np.linspace(1.0, 200.0, 60)
    phases = rng.uniform(0, 2 * np.pi, freqs.size)
    u = 0.1 * np.sin(2 * np.pi * freqs * t[:, None] + phases).sum(axis=1)
    u = (u / np.sqrt(freqs.size / 2))[:, None]
    omega = 2 * np.pi * 60
    truth = StateSpaceModel(
        duffing,
        {
            "g": omega**2,
            "d": 20.0,
            "k1": omega**2,
            "k2": 0.0,
            "k3": 10 * omega**2,
            "c": 0.0,
        },
        state_names=["output", "derivative (latent)"],
        observed=["output"],
        dt=DT,
        input_points=3,
    ).initialize()
    y = truth.simulate_from_state(band_limited_inputs(u), np.zeros(2))
    y = y + 1e-4 * rng.normal(size=y.shape)
    return np.split(u, N_PIECES), np.split(y, N_PIECES)


def silverbox_records(folder):
    """The estimation record, cut into six pieces; no test record is read."""
    from skhybrid.benchmarks import benchmark_spec

    U, Y = benchmark_spec("silverbox", folder).estimation_records()
    u, y = np.concatenate(U), np.concatenate(Y)
    return np.array_split(u, N_PIECES), np.array_split(y, N_PIECES)


@contextlib.contextmanager
def joint_training():
    """Record the state-space hybrid's joint training: its module, data, settings.

    Yields
    ------
    seen : dict
        Filled by a fit inside: ``module`` (a copy at its start), ``X``, ``y``
        and ``kwargs``, the arguments of its ``train_module`` call.
    """
    seen = {}
    original = state_space.train_module

    def spy(est, make_module, X, y, **kwargs):
        if kwargs.get("sequences"):
            seen.update(module=copy.deepcopy(make_module()), X=X, y=y, kwargs=kwargs)
        return original(est, make_module, X, y, **kwargs)

    state_space.train_module = spy
    try:
        yield seen
    finally:
        state_space.train_module = original


def capture(U, Y):
    """A one-epoch fit on the CPU; the joint training's module and data."""
    Ub = [band_limited_inputs(u) for u in U]
    model = StateSpaceHybridRegressor(
        physics_from_records(Ub, Y, DT),
        n_init=50,
        warm_start_physics=False,
        random_state=0,
        compile_rollout=False,
        **hybrid_settings(
            50, (64, 64), corrected_states=["derivative (latent)"], max_epochs=1
        ),
    )
    with joint_training() as seen, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit_simulation(Ub, Y)
    return model, seen


def epochs(model, seen, device, epochs, compile_kwargs, step=False):
    """Train ``epochs`` epochs on ``device``; the epochs' and the whole's seconds.

    ``compile_kwargs`` compile the whole module, ``step`` one sample's step.
    """
    est = copy.copy(model).set_params(device=device, max_epochs=epochs, patience=None)
    module = copy.deepcopy(seen["module"]).to(device)
    if step:
        module.compile_step({})
    kwargs = dict(seen["kwargs"], compile_kwargs=compile_kwargs)
    valid = kwargs.pop("valid")
    if valid is not None:
        valid = tuple(v.to(device) for v in valid)
    X, y = seen["X"].to(device), seen["y"].to(device)
    torch._dynamo.reset()
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        net = state_space.train_module(est, lambda: module, X, y, valid=valid, **kwargs)
    if device == "cuda":
        torch.cuda.synchronize()
    return list(net.history[:, "dur"]), time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", help="folder of the Silverbox files")
    parser.add_argument("--epochs", type=int, default=4)
    parser.add_argument(
        "--samples",
        type=int,
        default=PIECE,
        help="samples of each simulated record (a smoke test takes fewer)",
    )
    args = parser.parse_args()
    if args.data:
        U, Y = silverbox_records(args.data)
    else:
        U, Y = simulated_records(args.samples)
    model, seen = capture(U, Y)
    print(
        f"{'Silverbox estimation record' if args.data else 'simulated records'}: "
        f"{sum(len(u) for u in U)} samples, {len(seen['X'])} sub-sequences of "
        f"horizon {model.horizon}, batch {model.batch_size}, hidden "
        f"{model.hidden_layer_sizes}; {args.epochs} epochs each"
    )
    # The cheapest first: where the slot runs out, the others are printed.
    torch.set_num_threads(os.cpu_count())
    threads = torch.get_num_threads()
    rows = {
        f"cpu, {threads} threads": ("cpu", None),
        f"cpu step, {threads} threads": ("cpu", None, True),
    }
    cuda = torch.cuda.is_available()
    if cuda:
        rows["cuda eager"] = ("cuda", None)
        rows["cuda step"] = ("cuda", None, True)
        # Static shapes: a CUDA graph a batch size, recorded without inductor.
        rows["cuda graphs only"] = (
            "cuda",
            {"backend": "cudagraphs", "dynamic": False},
        )
        rows["cuda captured"] = ("cuda", {"mode": "reduce-overhead"})
    median = {}
    for name, (device, compile_kwargs, *step) in rows.items():
        durs, total = epochs(model, seen, device, args.epochs, compile_kwargs, *step)
        median[name] = float(np.median(durs[1:] if len(durs) > 1 else durs))
        print(
            f"{name:>20}: first epoch {durs[0]:7.2f} s, median epoch "
            f"{median[name]:7.3f} s, training {total:7.1f} s",
            flush=True,
        )
    if not cuda:
        cpu, step = median.values()
        print(f"{'cpu step':>20}: {cpu / step:5.2f}x faster than the cpu eager")
        print("The GPU rows (cuda eager, step, captured) need a CUDA device.")
        return
    cpu = median[next(iter(rows))]
    for name in rows:
        if name.startswith("cuda"):
            print(
                f"{name:>20}: {median['cuda eager'] / median[name]:5.2f}x faster "
                f"than cuda eager, {cpu / median[name]:5.2f}x faster than the cpu"
            )


if __name__ == "__main__":
    main()
