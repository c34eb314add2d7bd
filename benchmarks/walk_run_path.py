"""Follow a spec through the measured path of ``run_system``: its stays and returns.

A tiny toy spec (a mass on a stiffening spring with friction, two estimation
records of 300 and 200 samples, a simulated test record) runs with
``run_system(spec, out, seeds=0, quick=True, n_jobs=1, progress=False)`` into a
temporary folder while :func:`sys.settrace` watches every Python call of the
main thread. What is counted:

- a *hand-off* is a call of a function whose code lives in a module of
  ``skhybrid.experiments`` (the package and every module below it;
  comprehensions and generators, context managers' included, aside) with an
  argument other than ``self`` or ``cls`` (directly, or as an item of a
  tuple, list or dict argument) that is the spec object itself or a system
  bound to it (an object whose instance ``__dict__`` holds the spec, as
  ``MeasuredSystem`` does). This follows the spec *as data*: the functions it
  is handed to, not the questions asked of it (its own methods, the system's).
- each function is counted once, at its first hand-off: the run's loops over
  models, folds and candidates repeat a walk already made.
- the *module* of a hand-off is its code's module (``f_globals["__name__"]``);
  a *stay* is a maximal run of consecutive hand-offs in one module, and a
  *return* a stay in a module that an earlier stay left.
- the same, with *rooms* for modules: a room is the subpackage of
  ``skhybrid.experiments`` a module sits in (``run``, ``free_run``,
  ``one_step``), or the module itself at the package's top level.

Calls in other threads and in worker processes are not seen (``n_jobs=1``
keeps the run's own calls in this thread). It prints the counts and the
sequence of stays (module, the functions handed the spec there, "return"). The
toy is simulated; no benchmark's test record is read.

Usage::

    python benchmarks/walk_run_path.py [--quiet]
"""

import argparse
import inspect
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments import SystemSpec, run_system

PACKAGE = "skhybrid.experiments"
#: ``co_flags`` of a generator, a coroutine and an async generator.
GENERATOR_FLAGS = (
    inspect.CO_GENERATOR | inspect.CO_COROUTINE | inspect.CO_ASYNC_GENERATOR
)
DT = 0.05


def _measure(n_samples, seed):
    """A record ``(u, y)`` of the toy machine, force in, position out."""
    rng = np.random.default_rng(seed)
    force = np.repeat(rng.uniform(-3, 3, n_samples // 40 + 1), 40)[:n_samples]
    x, v, h, y = 0.0, 0.0, DT / 10, np.empty(n_samples)
    for t in range(n_samples):
        y[t] = x
        for _ in range(10):
            accel = force[t] - 4 * x - 6 * x**3 - 0.3 * v - 0.4 * np.tanh(v / 0.01)
            x, v = x + h * v, v + h * accel
    y += 0.005 * rng.standard_normal(n_samples)
    return force[:, None], y[:, None]


def spring_damper(x, u, *, xp, k, c, fc):
    """The toy's physics: a linear spring and damper with Coulomb friction."""
    position, velocity = x[:, 0], x[:, 1]
    accel = u[:, 0] - k * position - c * velocity - fc * xp.tanh(velocity / 0.01)
    return xp.stack([velocity, accel], axis=1)


def toy_spec():
    """The tiny spec the walk follows."""
    physics = StateSpaceModel(
        spring_damper,
        {"k": 2.0, "c": 1.0, "fc": 0.1},
        state_names=["position", "velocity"],
        observed=["position"],
        time="continuous",
    )
    return SystemSpec(
        "walk-toy",
        records=[_measure(300, 0), _measure(200, 1)],
        physics=physics,
        n_init=10,
        dt=DT,
        tests={"test": _measure(200, 2)},
        unit="m",
    )


def _holds_spec(value, spec):
    """Whether ``value`` is the spec or a system bound to it (no property is run)."""
    if value is spec:
        return True
    try:
        attributes = object.__getattribute__(value, "__dict__")
    except (AttributeError, TypeError):
        return False
    if not isinstance(attributes, dict):
        return False
    return any(v is spec for v in attributes.values())


def _is_comprehension(code):
    return code.co_name.startswith("<") and code.co_name != "<module>"


def _function_name(code, local):
    """A function's qualified name; a generated ``__init__`` by its class."""
    if code.co_filename.startswith("<") and "self" in local:
        return f"{type(local['self']).__qualname__}.{code.co_name}"
    return code.co_qualname


def walk(spec, out):
    """Run the spec into ``out``; the functions it was handed to, in order.

    Returns
    -------
    handoffs : list of tuple of str
        ``(module, function)`` of each function's first hand-off.
    """
    calls = []
    main = threading.main_thread()

    def tracer(frame, event, arg):
        if event != "call" or threading.current_thread() is not main:
            return
        module = frame.f_globals.get("__name__", "")
        if module != PACKAGE and not module.startswith(PACKAGE + "."):
            return
        code = frame.f_code
        if _is_comprehension(code) or code.co_flags & GENERATOR_FLAGS:
            return
        n_args = code.co_argcount + code.co_kwonlyargcount
        n_args += bool(code.co_flags & inspect.CO_VARARGS)
        n_args += bool(code.co_flags & inspect.CO_VARKEYWORDS)
        local = frame.f_locals
        for name in code.co_varnames[:n_args]:
            if name in ("self", "cls"):
                continue
            value = local.get(name)
            if isinstance(value, (tuple, list)):
                held = any(_holds_spec(v, spec) for v in value)
            elif isinstance(value, dict):
                held = any(_holds_spec(v, spec) for v in value.values())
            else:
                held = _holds_spec(value, spec)
            if held:
                calls.append((module, _function_name(code, local)))
                break
        return

    sys.settrace(tracer)
    try:
        run_system(spec, out, seeds=0, quick=True, n_jobs=1, progress=False)
    finally:
        sys.settrace(None)
    return list(dict.fromkeys(calls))


def room(module):
    """The subpackage of ``skhybrid.experiments`` holding ``module``, or itself."""
    parts = module[len(PACKAGE) + 1 :].split(".")
    return parts[0] if len(parts) > 1 else module[len(PACKAGE) + 1 :]


def stays_of(handoffs, where=lambda module: module):
    """The stays ``[(place, [functions])]`` and the indices of the returns."""
    stays = []
    for module, function in handoffs:
        place = where(module)
        if stays and stays[-1][0] == place:
            stays[-1][1].append(function)
        else:
            stays.append((place, [function]))
    left, returns = set(), []
    for i, (place, _) in enumerate(stays):
        if place in left:
            returns.append(i)
        if i > 0:
            left.add(stays[i - 1][0])
    return stays, returns


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quiet", action="store_true", help="the counts only")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        handoffs = walk(toy_spec(), Path(tmp) / "run")
    stays, returns = stays_of(handoffs)
    rooms, room_returns = stays_of(handoffs, room)
    print(
        f"hand-offs {len(handoffs)}; by module: stays {len(stays)}, returns "
        f"{len(returns)}; by room: stays {len(rooms)}, returns {len(room_returns)}"
    )
    if args.quiet:
        return 0
    for title, places, back in (
        ("module", stays, returns),
        ("room", rooms, room_returns),
    ):
        print(f"\nby {title}:")
        for i, (place, functions) in enumerate(places):
            short = place[len(PACKAGE) + 1 :] if place.startswith(PACKAGE) else place
            mark = "  return" if i in back else ""
            print(f"{i + 1:3d}  {short or '(package)'}: {', '.join(functions)}{mark}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
