"""What ``import uvms`` and a command load: the top level's names and layers are imported at their first use, and
scipy.optimize, matplotlib, numba and tqdm only by what uses them. A test of imports, not of time."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import uvms

from conftest import ROOT

#: Libraries that only some runs need: none may load with ``import uvms`` or the command line's parser.
ON_USE = ("scipy", "matplotlib", "numba", "tqdm", "yaml", "xacro", "rosbags", "joblib", "qpsolvers", "multiprocessing")


def modules_after(code: str) -> set[str]:
    """The modules a fresh interpreter holds after running ``code``."""
    script = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    output = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT)
    return set(json.loads(output.stdout.splitlines()[-1]))


def libraries(modules: set[str]) -> set[str]:
    return {name for name in ON_USE if name in modules}


def test_import_uvms_loads_the_errors_only():
    modules = modules_after("import uvms")
    assert sorted(name for name in modules if name.startswith("uvms")) == ["uvms", "uvms.errors"]
    assert libraries(modules) == set()


def test_the_command_line_and_a_quiet_run_load_what_they_use_only():
    assert libraries(modules_after("import uvms.cli; uvms.cli.build_parser()")) == set()
    run = ("import uvms, numpy as np\n"
           "robot = uvms.load('hoang2011')\n"
           "task = uvms.FrameTask(robot, axes=('x', 'y', 'yaw'))\n"
           "q0 = robot.configuration(base=[0.0, 0.0, 0.0], arm=[1.0, 0.5, 0.2])\n"
           "task.set_target(robot.fk(q0))\n"
           "solver = uvms.CLIKSolver(robot, task)\n"
           "class Law:\n"
           "    def reset(self, state, t=0.0): pass\n"
           "    def command(self, state, t):\n"
           "        r = solver.velocity(uvms.Configuration(robot, state.q))\n"
           "        return uvms.control.Command(velocity=r.v, info=r)\n"
           "controller = Law()\n"
           "uvms.simulate(robot, controller, q0, 0.1, 0.01, progress=False)")
    modules = modules_after(run)
    assert "numba" in modules and "scipy.linalg" in modules  # the CLIK's kernels, LAPACK for the RK4 stages
    assert libraries(modules) - {"numba", "scipy", "yaml", "xacro"} == set()  # hoang2011 is a xacro (it reads YAML)
    assert "scipy.optimize" not in modules and "uvms.workspace" not in modules and "uvms.viz" not in modules


def test_a_layer_or_a_name_of_the_top_level_is_imported_at_its_first_use():
    from uvms.dynamics.thrusters.allocation import ThrustAllocator
    from uvms.model import load

    assert uvms.dynamics.ThrustAllocator is ThrustAllocator and uvms.load is load
    assert set(uvms.__all__) | set(uvms.LAYERS) <= set(dir(uvms))
    with pytest.raises(AttributeError, match="top-level names are UVMSError, load, Robot"):
        uvms.PlantResult  # noqa: B018 - a name of before the layers
