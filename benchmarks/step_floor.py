"""The compiled floor of the intervention step (issue 46): what a step costs with no Python between its calls.

One step of ``scenarios/bluerov2_alpha5_intervention.toml`` (its 500th: the run warm, the arm moving) is recorded:
every numba kernel, every Pinocchio function and every numpy LAPACK call it makes, each with a copy of its arguments.
They are then replayed back to back, in the step's order, from a list: the same compiled arithmetic on the same
inputs, each call's own boundary crossing (numba's dispatch, Boost.Python's conversions) kept, the controller's and
the integrator's Python between them gone. The replay's time, as a ratio to one ``pin.aba`` on the same model
timed beside it, is what the step would cost if all of its glue were compiled away with its numerics unchanged
(bit for bit) and its calls kept apart; per call, what each kernel costs. Numba's crossing of each kernel call
(reading its arguments: a no-op kernel called with the same arguments) is measured apart: what fusing the step's
kernels into fewer calls would take off the floor.

The thin step is the floor's replay with each call made through one Python function that makes one output array:
the least Python a step sequenced from Python between its compiled calls could have (what a step whose Python only
passes prepared arrays from one call to the next would cost). ``--gaps`` times, over steps 101-900 of the run, the
Python between each two consecutive compiled calls (each call's wrapper stamps its start and end), summed by pair
of calls: where the step's Python is, segment by segment, and so what a thin step would take off where.

The recording replaces numba's dispatcher call and ``pinocchio``'s module functions in this process only (the
script's own process: nothing else imports them patched); it reads numba's ``Dispatcher`` type, so it follows the
numba of this environment.

    python benchmarks/step_floor.py [--rounds 3] [--step 500] [--gaps]
"""

from __future__ import annotations

import argparse
import functools
import json
import time
import timeit
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin
from numba import _dispatcher
from numba.core import dispatcher

import uvms

ROOT = Path(uvms.__file__).resolve().parent.parent  # the checkout imported (PYTHONPATH=OLD_TREE: before/after)
SCENARIO = ROOT / "scenarios" / "bluerov2_alpha5_intervention.toml"

Call = tuple[str, Callable, tuple]  # (kind:name, the original callable, copies of its arguments)
#: numba's own call of a kernel (the C type's), which :meth:`Recorder.install` leaves in place: the replays and the
#: no-op kernels call through it, not through the recorder's wrapper
NUMBA_CALL = _dispatcher.Dispatcher.__call__


class Recorder:
    """The compiled calls of the step: wraps numba's dispatch, Pinocchio's functions and the LAPACK entry points
    uvms calls, and keeps (name, callable, copied arguments) while :attr:`on`; with ``timing``, sums instead the time
    [s] between the end of a call and the start of the next, by (previous call, call) in :attr:`gaps`."""

    def __init__(self, timing: bool = False) -> None:
        self.on, self.calls, self.timing = False, [], timing
        self.gaps: Counter = Counter()
        self.previous, self.ended = "step", 0.0
        self.aba = pin.aba  # the reference, unwrapped

    def keep(self, name: str, function: Callable, args: tuple) -> None:
        if self.on and not self.timing:
            self.calls.append((name, function, tuple(map(_typed_copy, args))))

    def mark(self, name: str) -> None:
        """While timing: the gap since the last call ends at a call (or the step's start) called ``name``."""
        if self.on and self.timing:
            self.gaps[(self.previous, name)] += time.perf_counter() - self.ended

    def done(self, name: str) -> None:
        self.previous, self.ended = name, time.perf_counter()

    def install(self) -> None:
        """Wrap the three kinds of compiled call (before uvms binds any of them)."""
        recorder = self

        def numba_call(kernel, *args, **keywords):
            name = f"numba:{kernel.py_func.__name__}"
            recorder.keep(name, functools.partial(NUMBA_CALL, kernel), args)
            recorder.mark(name)
            result = NUMBA_CALL(kernel, *args, **keywords)
            recorder.done(name)
            return result

        dispatcher.Dispatcher.__call__ = numba_call
        for name in dir(pin):
            function = getattr(pin, name)
            if type(function).__name__ == "function" and not name.startswith("_"):  # Boost.Python's functions
                setattr(pin, name, self._wrapped(f"pin:{name}", function))
        from uvms.numerics import lapack

        for name in ("_solve_vector", "_solve_matrix"):  # numpy's LAPACK gufuncs behind numpy_solve
            setattr(lapack, name, self._wrapped(f"numpy:{name}", getattr(lapack, name), signature="dd->d"))

    def _wrapped(self, name: str, function: Callable, **fixed) -> Callable:
        def wrapper(*args, **keywords):
            self.keep(name, (lambda *a: function(*a, **fixed)) if fixed else function, args)
            self.mark(name)
            result = function(*args, **keywords)
            self.done(name)
            return result

        return wrapper


def _typed_copy(argument: object) -> object:
    """An array argument's copy typed as the array (its memory order and its read-only flag: a kernel replayed with it
    runs the specialization the step ran, none compiled for the copy); anything else as it is."""
    if not isinstance(argument, np.ndarray):
        return argument
    copy = argument.copy(order="K")
    copy.flags.writeable = argument.flags.writeable
    return copy


def run_counted(recorder: Recorder, first: int, last: int) -> pin.Model:
    """The intervention run with ``recorder`` installed and on from step ``first``'s sample to the end of step
    ``last`` (counted by the plant's samples); the model."""
    recorder.install()
    import uvms.dynamics.plant.actuated as actuated
    from uvms.scenario.actuated import simulate_actuation
    from uvms.scenario.build import build
    from uvms.scenario.schema import read_scenario

    spec = read_scenario(SCENARIO, ["outputs.figures=false"])
    setup = build(spec)
    samples = getattr(setup, "samples", None) or setup.trajectory
    sample, count = actuated.ActuatedPlantSystem.sample, [0]

    def counted(system, *args):
        recorder.mark("step")  # the last step's end to this one's start
        count[0] += 1
        recorder.on = first <= count[0] <= last
        recorder.done("step")
        return sample(system, *args)

    actuated.ActuatedPlantSystem.sample = counted
    # the run up to the sample after step ``last`` (what comes after is never read; half the run for the floor's
    # step 500, which matters under callgrind)
    duration = min(setup.duration, last * float(spec.simulation.dt))
    for _ in range(2 if recorder.timing else 1):  # timing: a first run loads the kernels
        count[0] = 0
        recorder.gaps.clear()
        simulate_actuation(setup.actuation, setup.task, samples, setup.q0, duration, spec.simulation, False)
    actuated.ActuatedPlantSystem.sample = sample
    return setup.robot.model


def record_step(step: int) -> tuple[list[Call], pin.Model, Callable]:
    """The calls of the run's step ``step`` (counted by the plant's samples), the model and pin.aba unwrapped."""
    recorder = Recorder()
    model = run_counted(recorder, step, step)
    if not recorder.calls:
        raise SystemExit(f"the run has fewer than {step} steps")
    return recorder.calls, model, recorder.aba


def gap_times(first: int = 101, last: int = 900) -> tuple[Counter, int, float]:
    """(the Python between consecutive compiled calls [s] summed by (previous call, call) over steps ``first`` to
    ``last``, the number of steps, one pin.aba [s])."""
    recorder = Recorder(timing=True)
    model = run_counted(recorder, first, last)
    return recorder.gaps, last - first + 1, aba_time(model, recorder.aba)


def aba_time(model: pin.Model, aba: Callable, number: int = 5000) -> float:
    """One pin.aba [s] on the model at a random state, best of 5."""
    data, rng = model.createData(), np.random.default_rng(0)
    q = pin.integrate(model, pin.neutral(model), 0.3 * rng.normal(size=model.nv))
    v, tau = 0.3 * rng.normal(size=model.nv), np.zeros(model.nv)
    return min(timeit.repeat(lambda: aba(model, data, q, v, tau), number=number, repeat=5)) / number


def replay(calls: list[Call]) -> None:
    for _, function, args in calls:
        function(*args)


def thin_replay(calls: list[Call], size: int = 11) -> None:
    """The replay, each call made through one Python function that makes one output array (``size``,): the thin
    step."""
    for _, function, args in calls:
        _through(function, args, size)


def _through(function: Callable, args: tuple, size: int):
    np.empty(size)  # the call's output, as a step made of prepared calls would make it
    return function(*args)


def replay_times(calls: list[Call], model: pin.Model, aba: Callable,
                 rounds: int) -> list[tuple[float, float, float]]:
    """(the step's calls replayed, the thin step, one pin.aba beside them) [s] per round, each the best of 5 x 200
    replays."""
    replay(calls)
    thin_replay(calls, model.nv)
    times = []
    for _ in range(rounds):
        reference = aba_time(model, aba)
        floor = min(timeit.repeat(lambda: replay(calls), number=200, repeat=5)) / 200
        thin = min(timeit.repeat(lambda: thin_replay(calls, model.nv), number=200, repeat=5)) / 200
        times.append((floor, thin, reference))
    return times


def noop_calls(calls: list[Call]) -> list[tuple[Callable, tuple]]:
    """The step's numba calls as no-op kernels of as many arguments, each with its call's own arguments (numba's
    dispatch and unboxing, no arithmetic), compiled here (called once each): one no-op per signature of arguments,
    so that each has one specialization as the step's kernels have, each called through numba's own call (not the
    recorder's Python wrapper, which :meth:`Recorder.install` put on every dispatcher of this process)."""
    from numba import njit, typeof

    noops: dict[tuple, Callable] = {}
    replayed = []
    for name, _, args in calls:
        if name.startswith("numba:"):
            signature = tuple(map(typeof, args))
            if signature not in noops:
                names = ", ".join(f"a{index}" for index in range(len(args)))
                namespace: dict = {}
                exec(f"def noop({names}):\n    return 0\n", namespace)  # the script's own source, no input
                noops[signature] = functools.partial(NUMBA_CALL, njit(cache=False)(namespace["noop"]))
                noops[signature](*args)
            replayed.append((noops[signature], args))
    return replayed


def numba_crossing(calls: list[Call]) -> float:
    """The numba calls' crossing [s]: :func:`noop_calls`, each best of 5 x 2,000, summed over the step."""
    return sum(min(timeit.repeat(lambda: noop(*args), number=2000, repeat=5)) / 2000  # noqa: B023
               for noop, args in noop_calls(calls))


def print_gaps(count: int = 25) -> None:
    """``--gaps``: the Python between the step's compiled calls, by pair of calls, the largest first."""
    gaps, steps, reference = gap_times()
    total = sum(gaps.values()) / steps
    print(f"checkout {ROOT}: the Python between the step's compiled calls, steps 101-900 (pin.aba "
          f"{1e6 * reference:.2f} us): {1e6 * total:.1f} us a step = {total / reference:.0f}x aba, each gap with "
          f"its wrappers' own stamps; by pair of calls (x aba a step, calls a step):")
    pairs = Counter({pair: seconds / steps for pair, seconds in gaps.items()})
    for (previous, name), seconds in pairs.most_common(count):
        print(f"| {previous} -> {name} | {1e6 * seconds:.2f} us | {seconds / reference:.1f}x |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="replays timed (each against its own pin.aba)")
    parser.add_argument("--step", type=int, default=500, help="the step recorded")
    parser.add_argument("--gaps", action="store_true",
                        help="time the Python between the step's compiled calls instead, by pair of calls")
    parser.add_argument("--json", action="store_true",
                        help="print only the replays' times as JSON ({\"step\": [s], \"thin\": [s], \"aba\": [s]}), "
                             "for bench_actuated.py's table")
    options = parser.parse_args()
    if options.gaps:
        print_gaps()
        return
    calls, model, aba = record_step(options.step)
    times = replay_times(calls, model, aba, options.rounds)
    if options.json:
        print(json.dumps({"step": [floor for floor, _, _ in times], "thin": [thin for _, thin, _ in times],
                          "aba": [reference for _, _, reference in times]}))
        return
    kinds = Counter(name.split(":")[0] for name, _, _ in calls)
    print(f"checkout {ROOT}: step {options.step}, {len(calls)} compiled calls ({dict(kinds)})")
    for floor, thin, reference in times:
        print(f"| the step's compiled calls replayed (pin.aba {1e6 * reference:.2f} us) | {1e6 * floor:.1f} us = "
              f"**{floor / reference:.0f}x aba** | the thin step {1e6 * thin:.1f} us = **{thin / reference:.0f}x** |")
    reference = aba_time(model, aba)
    totals: dict[str, list] = {}
    for name, function, args in calls:
        each = min(timeit.repeat(lambda: function(*args), number=500, repeat=3)) / 500
        totals.setdefault(name, [0, 0.0])
        totals[name][0] += 1
        totals[name][1] += each
    crossing = numba_crossing(calls)
    print(f"median {np.median([floor / ref for floor, _, ref in times]):.0f}x aba, of which numba's crossing of its "
          f"{kinds['numba']} kernel calls {1e6 * crossing:.1f} us = {crossing / reference:.1f}x aba (no-op kernels "
          f"with the same arguments); per call (the sum of its calls in the step, x aba):")
    for name, (number, total) in sorted(totals.items(), key=lambda item: -item[1][1]):
        print(f"| {name} | x{number} | {1e6 * total:.2f} us | {total / reference:.1f}x |")


if __name__ == "__main__":
    main()
