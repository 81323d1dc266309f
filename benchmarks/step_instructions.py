"""The intervention step in instructions (issue 46): what a step executes, by who executes it, as a ratio to pin.aba.

Wall-clock ratios on this machine move by 30-60 % within an hour (shared cores); the instructions a step executes do
not. Under valgrind's callgrind, one process runs the intervention (``scenarios/bluerov2_alpha5_intervention.toml``,
built once, its kernels loaded by a short first run) for ``LOW`` steps and another for ``LOW + --steps`` steps; their
difference over ``--steps`` is one step (its share of the run's after-loop series included). Two more processes
count ``pin.aba`` on the same model the same way. Each count is read from callgrind's file (:func:`object_costs`:
code inlined from headers included) and split by the shared object its instructions ran in:

* compiled work: numba's kernels (JIT code, no object), BLAS and LAPACK, Pinocchio's algorithms (in its library, or
  compiled into its Python module as aba is), coal;
* calling it from Python: the interpreter, numpy's C API (arrays made and indexed, ufuncs on small vectors), the C
  library (malloc, free, memcpy), numba's dispatch and runtime, Pinocchio's bindings (boost::python, eigenpy and
  pinocchio::python's wrappers).

OpenBLAS runs on one thread here (``OPENBLAS_NUM_THREADS=1``): its idle workers spin, and callgrind would count the
spinning.

The step's floor (``step_floor.py``: its 79 compiled calls replayed back to back from a list, no Python between them)
is counted the same way, and taken apart: numba's crossing of its kernel calls (no-op kernels with the same
arguments, :func:`step_floor.noop_calls`), Pinocchio's and LAPACK's calls with their bindings, and the kernels' own
work (the rest); the step less its floor is the Python between the calls.

A ratio in instructions is not one in time: a step runs its instructions at a lower rate than aba runs its own, so
its time ratio (``bench_actuated.py``) is above its instruction ratio (100x against 116-135x on 2026-12-07; about
twice as much when the step had more Python). ``--cache`` says why: with
callgrind's cache simulation (a 64 KiB L1 instruction cache, 48 KiB L1 data, a 2 MiB L2 as the last level: this
machine's, ``--caches`` to model another) it adds each run's misses per step and per aba, and a step's misses by
the component they happened in (the instruction table's): a step's code does not fit the L1 instruction cache, aba's
does.

The numba cache is keyed by the CPU numba sees, and valgrind's is another: after a kernel's source changes (or on a
first run) valgrind's kernels are compiled again, which the two counted runs would each do, in unequal counts.
One uncounted run under valgrind first compiles them into the cache; the counted runs load them
(``PYTHONHASHSEED=0`` in every run).

    python benchmarks/step_instructions.py [--steps 200] [--no-floor] [--cache]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "scenarios" / "bluerov2_alpha5_intervention.toml"
LOW = 10  # steps of the shorter run: its fixed costs (imports, the build, the first run) cancel in the difference
#: The caches ``--cache`` simulates by default (valgrind's size,associativity,line): this machine's L1 instruction and
#: data caches and its 2 MiB L2 as the last level (its L3 is shared with other machines' work)
CACHES = ("65536,8,64", "49152,12,64", "2097152,16,64")

#: Pinocchio's algorithms are compiled into its Python module as well as into its library (pin.aba's work runs in the
#: module): there a function of the binding layers (boost::python's calls, eigenpy's conversions, pinocchio::python's
#: wrappers) counts as the bindings, any other (an algorithm, Eigen's code) as Pinocchio's algorithms, under this
#: prefix of its object's name.
BINDING_LAYERS = ("boost::python", "eigenpy", "pinocchio::python")
ALGORITHMS = "pinocchio's algorithms in "
#: (substring of a shared object's file name, component), the first match wins; JIT code has no object ("???")
COMPONENTS = (
    (ALGORITHMS, "Pinocchio's algorithms"),
    ("???", "numba's kernels (JIT code)"),
    ("openblas", "BLAS and LAPACK"), ("_flapack", "BLAS and LAPACK"), ("_fblas", "BLAS and LAPACK"),
    ("cython_blas", "BLAS and LAPACK"), ("cython_lapack", "BLAS and LAPACK"),
    ("libpinocchio", "Pinocchio's algorithms"), ("libcoal", "coal"),
    ("libpython", "the interpreter"), ("_multiarray_umath", "numpy's C API"), ("_umath_linalg", "numpy's C API"),
    ("libc.so", "the C library (malloc, free, memcpy)"), ("libm.so", "the C library (malloc, free, memcpy)"),
    ("_dispatcher", "numba's dispatch and runtime"), ("_nrt_python", "numba's dispatch and runtime"),
    ("_helperlib", "numba's dispatch and runtime"),
    ("pinocchio_pywrap", "Pinocchio's bindings"), ("boost_python", "Pinocchio's bindings"),
    ("eigenpy", "Pinocchio's bindings"),
)
COMPILED = ("numba's kernels (JIT code)", "BLAS and LAPACK", "Pinocchio's algorithms", "coal")

CHILD = """
import sys
import numpy as np
import pinocchio as pin
from uvms.scenario.actuated import simulate_actuation
from uvms.scenario.build import build
from uvms.scenario.schema import read_scenario

kind, count, scenario = sys.argv[1], int(sys.argv[2]), sys.argv[3]
if kind in ("floor", "crossing", "pinocchio"):  # step_floor.py's recorded step, replayed
    sys.path.insert(0, sys.argv[4])
    import step_floor

    calls = step_floor.record_step(500)[0]
    replayed = (step_floor.noop_calls(calls) if kind == "crossing" else
                [(function, args) for name, function, args in calls
                 if kind == "floor" or not name.startswith("numba:")])
    for _ in range(count + 1):  # the first replay warms
        for function, args in replayed:
            function(*args)
    sys.exit()
spec = read_scenario(scenario, ["outputs.figures=false"])
setup = build(spec)
if kind == "step":
    samples = getattr(setup, "samples", None) or setup.trajectory
    dt = float(spec.simulation.dt)
    simulate_actuation(setup.actuation, setup.task, samples, setup.q0, 5 * dt, spec.simulation, False)  # kernels in
    simulate_actuation(setup.actuation, setup.task, samples, setup.q0, count * dt, spec.simulation, False)
else:
    model = setup.actuation.actuated.plant.model
    data, rng = model.createData(), np.random.default_rng(0)
    q = pin.integrate(model, pin.neutral(model), 0.3 * rng.normal(size=model.nv))
    v, tau = 0.3 * rng.normal(size=model.nv), np.zeros(model.nv)
    for _ in range(count):
        pin.aba(model, data, q, v, tau)
"""


#: The cache misses ``--cache`` reports: (label, callgrind's events summed), of a run's totals.
MISSES = (("L1 instruction misses", ("I1mr",)), ("L1 data misses", ("D1mr", "D1mw")),
          ("last-level misses", ("ILmr", "DLmr", "DLmw")))
MISSED = frozenset(label for label, _ in MISSES)  # the labels, kept apart from the instructions' components


def counted_run(kind: str, count: int, folder: Path, caches: tuple[str, str, str] | None = None) -> Counter:
    """Instructions by shared object of one child process under callgrind: ``count`` steps, pin.aba calls or
    replays of the step's floor (``kind`` "step", "aba", "floor", "crossing" or "pinocchio"); with ``caches`` (I1,
    D1, LL as valgrind's size,associativity,line) also the run's cache misses, under the keys of :data:`MISSES`."""
    out = folder / f"{kind}_{count}.callgrind"
    environment = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}
    simulation = [] if caches is None else ["--cache-sim=yes", *(f"--{level}={size}" for level, size in
                                                                 zip(("I1", "D1", "LL"), caches))]
    subprocess.run(["valgrind", "--tool=callgrind", *simulation, f"--callgrind-out-file={out}", sys.executable, "-c",
                    CHILD, kind, str(count), str(SCENARIO), str(ROOT / "benchmarks")], cwd=ROOT, env=environment,
                   check=True, capture_output=True)
    _, costs = object_costs(out)
    by_object: Counter = Counter()
    for name, values in costs.items():
        name = file_name(name)
        by_object[name] += values.get("Ir", 0)
        if caches is not None:  # each miss where it happened: (label, object), and the run's totals
            for label, names in MISSES:
                missed = sum(values.get(event, 0) for event in names)
                by_object[(label, name)] += missed
                by_object[label] += missed
    return by_object


def object_costs(path: Path) -> tuple[list[str], dict[str, dict[str, int]]]:
    """(the events, each shared object's own cost by event) of a callgrind output file, read as its format defines:
    every cost line is counted in the object of the function it is in (``ob=``), code inlined from a header (``fi=``,
    ``fe=``) included (callgrind_annotate lists such code without its object); the cost line after ``calls=`` is a
    call's inclusive cost and is left out. JIT code has no object (``???``); Pinocchio's algorithms in its Python
    module are counted under :data:`ALGORITHMS` + the module's name."""
    events: list[str] = []
    positions = 1
    objects: dict[str, str] = {}  # a compressed id "(n)" -> its name, objects and functions apart
    functions: dict[str, str] = {}
    current, function = "???", ""
    where = current  # the name the current function's lines count under, set where the object or function changes
    after_call = False
    costs: dict[str, list[int]] = {}
    with open(path) as lines:
        for line in lines:
            head = line[:1]
            if head.isdigit() or head in "+-*":
                if after_call:  # the call's inclusive cost: the callee's own lines count it
                    after_call = False
                    continue
                row = costs.setdefault(where, [0] * len(events))
                for index, value in enumerate(line.split()[positions:]):
                    row[index] += int(value)
            elif line.startswith(("ob=", "cob=", "fn=", "cfn=")):
                name = compressed_name(line, objects if "ob=" in line[:4] else functions)
                if line.startswith("ob="):
                    current = name
                elif line.startswith("fn="):
                    function = name
                in_module = "pinocchio_pywrap" in current and not any(layer in function for layer in BINDING_LAYERS)
                where = ALGORITHMS + current if in_module else current
            elif line.startswith("calls="):
                after_call = True
            elif line.startswith("events:"):
                events = line.split()[1:]
            elif line.startswith("positions:"):
                positions = len(line.split()) - 1
    return events, {name: dict(zip(events, row)) for name, row in costs.items()}


def file_name(name: str) -> str:
    """An object's file name without its folder, :data:`ALGORITHMS`' prefix kept."""
    prefix = ALGORITHMS if name.startswith(ALGORITHMS) else ""
    return prefix + name[len(prefix):].rsplit("/", 1)[-1]


def compressed_name(line: str, names: dict[str, str]) -> str:
    """The name a callgrind ``key=(id) name`` or ``key=(id)`` line gives (the id's first line defines it, ``names``
    keeps it); a line without an id gives its name as it is."""
    value = line.split("=", 1)[1].strip()
    if not value.startswith("("):
        return value
    key, _, name = value.partition(" ")
    if name:
        names[key] = name
    return names.get(key, "???")


def by_component(by_object: Counter) -> Counter:
    """Instructions by component (:data:`COMPONENTS`; "other" for an object none names); the cache misses' totals
    kept, their (label, object) counts summed by (label, component)."""
    components: Counter = Counter()
    for name, count in by_object.items():
        if isinstance(name, tuple):
            components[name[0], component_of(name[1])] += count
        else:
            components[name if name in MISSED else component_of(name)] += count
    return components


def component_of(name: str) -> str:
    """The component (:data:`COMPONENTS`) of a shared object's file name; "other" for one none names."""
    return next((label for key, label in COMPONENTS if key in name), "other")


def per_call(kind: str, low: int, high: int, folder: Path, caches: tuple[str, str, str] | None = None) -> Counter:
    """Instructions by component of one step or one aba (and cache misses with ``caches``): the difference of two
    runs over their count."""
    with ThreadPoolExecutor(2) as pool:  # the two runs in parallel (instructions do not depend on the load)
        short, long = pool.map(lambda count: by_component(counted_run(kind, count, folder, caches)), (low, high))
    return Counter({name: (long[name] - short[name]) / (high - low) for name in long | short})


def split_misses(counts: Counter) -> tuple[Counter, dict]:
    """(the instructions by component, the cache misses by label and by (label, component)) of :func:`per_call`'s
    counts."""
    return (Counter({name: value for name, value in counts.items() if not isinstance(name, tuple)
                     and name not in MISSED}),
            {name: value for name, value in counts.items() if isinstance(name, tuple) or name in MISSED})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="steps of the intervention counted")
    parser.add_argument("--abas", type=int, default=20000, help="pin.aba calls counted")
    parser.add_argument("--replays", type=int, default=200, help="replays of the step's floor counted")
    parser.add_argument("--no-floor", action="store_true", help="leave the floor's rows out")
    parser.add_argument("--cache", action="store_true", help="simulate the caches and report their misses too")
    parser.add_argument("--caches", nargs=3, metavar=("I1", "D1", "LL"), default=CACHES,
                        help="the simulated caches as valgrind's size,associativity,line (default: %(default)s)")
    options = parser.parse_args()
    caches = tuple(options.caches) if options.cache else None
    if shutil.which("valgrind") is None:
        sys.exit("step_instructions: valgrind is not installed (Debian: apt-get install valgrind)")
    print(f"checkout {ROOT}: {options.steps} steps of {SCENARIO.name} and {options.abas} pin.aba under callgrind",
          flush=True)
    with tempfile.TemporaryDirectory(prefix="uvms_step_instructions_") as name:
        folder = Path(name)
        counted_run("step", 1, folder)  # valgrind's kernels into numba's cache (compiled here after a change)
        step, step_misses = split_misses(per_call("step", LOW, LOW + options.steps, folder, caches))
        aba_counts, aba_misses = split_misses(per_call("aba", 0, options.abas, folder, caches))
        aba = sum(aba_counts.values())
        floor, floor_misses = {}, {}
        if not options.no_floor:
            for kind in ("floor", "crossing", "pinocchio"):
                counts, missed = split_misses(per_call(kind, 0, options.replays, folder,
                                                       caches if kind == "floor" else None))
                floor[kind] = sum(counts.values())
                floor_misses.update(missed)
    total = sum(step.values())
    print(f"| per step | instructions | x pin.aba ({aba / 1e3:.1f} k instructions) | share |")
    print("|---|---|---|---|")
    for group, labels in (("compiled work", COMPILED),
                          ("calling it from Python", [name for name in step if name not in COMPILED])):
        part = sum(step[label] for label in labels)
        print(row(f"**{group}**", part, aba, total, bold=True))
        for label in sorted(labels, key=lambda label: -step[label]):
            if step[label] >= 500:  # (coal: no query in this scenario's step)
                print(row(label, step[label], aba, total))
    print(row("**the step**", total, aba, total, bold=True))
    if floor:
        print(row("the step's floor: its compiled calls replayed, no Python between them (`step_floor.py`)",
                  floor["floor"], aba, total))
        print(row("... numba's crossing of its kernel calls (no-op kernels, the same arguments)", floor["crossing"],
                  aba, total))
        print(row("... Pinocchio's and LAPACK's calls, with their bindings", floor["pinocchio"], aba, total))
        print(row("... the kernels' own work (the rest)", floor["floor"] - floor["crossing"] - floor["pinocchio"],
                  aba, total))
        print(row("the step's Python between its calls (the step less its floor)", total - floor["floor"], aba,
                  total))
    if caches is not None:
        runs = [("a step", step_misses, total), ("one pin.aba", aba_misses, aba)]
        if floor_misses:
            runs.append(("the step's floor", floor_misses, floor["floor"]))
        print(f"\n| simulated caches (I1 {caches[0]}, D1 {caches[1]}, LL {caches[2]}) |"
              + "".join(f" {name} | per 1,000 instructions |" for name, _, _ in runs))
        print("|---|" + "---|---|" * len(runs))
        for label, _ in MISSES:
            cells = (f" {misses(counts[label])} | {1e3 * max(counts[label], 0.0) / executed:.1f} |"
                     for _, counts, executed in runs)
            print(f"| {label} |" + "".join(cells))
        print(f"\n| a step's misses by where they happened | {' | '.join(label for label, _ in MISSES)} |")
        print("|---|" + "---|" * len(MISSES))
        for component in sorted({name[1] for name in step_misses if isinstance(name, tuple)},
                                key=lambda part: -step_misses.get((MISSES[0][0], part), 0.0)):
            print(f"| {component} |" + "".join(f" {misses(step_misses.get((label, component), 0.0))} |"
                                               for label, _ in MISSES))


def misses(count: float) -> str:
    """A count of misses per step or per aba: "< 1" where the two runs' difference is below one (its noise can make
    it negative)."""
    return "< 1" if count < 1.0 else f"{count:,.1f}" if count < 100.0 else f"{count:,.0f}"


def row(label: str, count: float, aba: float, total: float, bold: bool = False) -> str:
    """A table row: instructions [k], x pin.aba's and the share of the step."""
    mark = "**" if bold else ""
    share = 100 * count / total
    return f"| {label} | {mark}{count / 1e3:.0f} k{mark} | {mark}{count / aba:.1f}x{mark} | {share:.0f} % |"


if __name__ == "__main__":
    main()
