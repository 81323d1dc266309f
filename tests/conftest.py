"""What the test files share: the repository's paths, the shipped models (loaded once per test session),
small model texts, and helpers for CLI output, xacro escapes and finite differences.

pytest puts this folder on sys.path when it loads this file, so a test file in any sub-folder imports these
with ``from conftest import ...`` (test basenames are unique across the folders: the default import mode).
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import settings

import uvms

ROOT = Path(__file__).resolve().parent.parent  # the repository
SCENARIOS = ROOT / "scenarios"
THRUSTER_BOX = ROOT / "tests" / "dynamics" / "thrusters" / "thruster_box.urdf"  # a box vehicle with eight thrusters
SHIPPED = sorted(uvms.model.shipped_models())
NO_FIGURES = ["outputs.figures=false"]  # a scenario override for runs whose figures are not under test


@functools.lru_cache(maxsize=None)
def shipped(name: str) -> uvms.Robot:
    """A shipped model, loaded once (tests must not mutate it)."""
    return uvms.load(name)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


# Property-based tests explore a fixed sequence of examples, so CI is reproducible; explore more locally with
# `pytest --hypothesis-seed=N` (a new seed per run) — that is how the zero-DOF crash was found.
settings.register_profile("reproducible", derandomize=True)
settings.load_profile("reproducible")


# ------------------------------------------------------------------ small models
INERTIAL = '<inertial><mass value="{mass}"/><inertia ixx="{ixx}" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'


def urdf(axis="0 0 1", xyz="1 0 0", mass="1", ixx="1", root="", extra="") -> str:
    """A two-link URDF with knobs for the values under test.

    Without ``root`` its root link ``base_link`` is massless (an arm's mounting link), so by uvms.load's base
    rule the probe is a fixed-base arm; with a vehicle joint in ``root``, ``base_link`` is the vehicle's body.
    """
    body = INERTIAL.format(mass=mass, ixx=ixx)
    return f"""<robot name="probe">{root}
      <link name="base_link">{body if root else ""}</link>
      <link name="l1">{body}</link>
      <joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/>
        <origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      {extra}</robot>"""


FLOATING_ROOT = ('<link name="world"/><joint name="float" type="floating"><parent link="world"/>'
                 '<child link="base_link"/></joint>')

#: a one-joint arm on a massless base: a fixed base by the base rule (``base="floating"`` makes it a vehicle)
FIXED_ARM = """<robot name="arm"><link name="base"/><link name="tip"><inertial><mass value="1"/>
  <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


MISSING_MESH = """<robot name="meshy">
  <link name="base_link"><visual><geometry><mesh filename="package://no_such_pkg/hull.stl"/></geometry></visual>
    <visual><geometry><box size="1 0.5 0.3"/></geometry></visual>
    <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/><origin xyz="0.5 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


# ------------------------------------------------------------------ xacro that escapes
# Escapes xacro's name filter through python.vars(python.type) to reach io.FileIO, then writes a file.
ESCAPE = ("[f for b in python.vars(python.type)['__subclasses__'](python.type(()).mro()[1]) if 'io._IOBase' in "
          "python.repr(b) for r in python.vars(python.type)['__subclasses__'](b) if 'RawIOBase' in python.repr(r) "
          "for f in python.vars(python.type)['__subclasses__'](r) if 'FileIO' in python.repr(f)][0]"
          "('{target}', 'w').write(b'owned')")


def xacro_file(folder: Path, expression: str) -> Path:
    path = folder / "model.urdf.xacro"
    path.write_text(f"""<?xml version="1.0"?>
<robot name="evil" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="payload" value="${{{expression}}}"/>
  <link name="world"/>
  <link name="hull{'${payload}'}"><inertial><mass value="10"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull{'${payload}'}"/></joint>
</robot>
""")
    return path


# Reaching the modules from xacro's restricted eval: a function's __globals__ through descriptors named by
# strings (xacro only filters names written in the expression), then builtins.__import__.
GLOBALS = ("python.vars(python.type(python.vars(python.type(abs_filename))['__globals__']))['__get__']"
           "(python.vars(python.type(abs_filename))['__globals__'], abs_filename)")
IMPORT = f"python.vars({GLOBALS}['sys'].modules['builtins'])['__import__']"


# ------------------------------------------------------------------ the CLI's output
ESCAPES = "\x1b]52;c;ZWNobyBwd25lZA==\x07\x1b[2K"  # OSC 52 (write the clipboard), then erase the line


def raising(exc: BaseException):
    """A command handler that raises ``exc``."""
    def handler(options):
        raise exc
    return handler


def one_line(capsys) -> str:
    """What the CLI wrote on stderr since the last read: exactly one line, ending in a newline."""
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert err.count("\n") == 1, err
    return err


# ------------------------------------------------------------------ numbers
def signed_numbers(rng: np.random.Generator, size: int) -> np.ndarray:
    """(size,) numbers over many scales, some exactly zero of either sign: what a kernel written to give numpy's or
    Pinocchio's bits is checked on (signed zeros included)."""
    values = rng.standard_normal(size) * 10.0 ** rng.uniform(-6, 3, size)
    values[rng.random(size) < 0.15] = 0.0
    values[rng.random(size) < 0.1] = -0.0
    return values


# ------------------------------------------------------------------ kinematics
def finite_difference_jacobian(robot: uvms.Robot, q: np.ndarray, frame: str, step: float = 1e-6) -> np.ndarray:
    """Central differences of fk along each velocity direction, on the manifold (pin.integrate).

    Linear rows: d(position)/dv; angular rows: log3(R+ R-^T) / (2 step), in world axes.
    """
    columns = []
    for index in range(robot.nv):
        direction = np.zeros(robot.nv)
        direction[index] = step
        plus = robot.fk(pin.integrate(robot.model, q, direction), frame)
        minus = robot.fk(pin.integrate(robot.model, q, -direction), frame)
        linear = (plus.translation - minus.translation) / (2 * step)
        angular = pin.log3(plus.rotation @ minus.rotation.T) / (2 * step)
        columns.append(np.concatenate([linear, angular]))
    return np.array(columns).T


def run_beside_clik(folder: Path, *selected: str) -> tuple[dict, dict]:
    """metrics.json of ``hoang2011_w1`` run by CLIK and by what ``selected`` (``--set`` values) chooses, both without
    CLIK's null-space term and with W = I (then CLIK is J+ (xdot_d + K e): the law a registered test method or
    controller implements), 20 s, figures off."""
    from uvms.cli import main

    common = ["--set", "outputs.figures=false", "--set", "simulation.duration=20", "--set", "solver.alpha=0",
              "--set", "solver.weights=[]", "--quiet"]
    chosen = [part for value in selected for part in ("--set", value)]
    assert main(["run", "hoang2011_w1", "--out", str(folder / "clik"), *common]) == 0
    assert main(["run", "hoang2011_w1", "--out", str(folder / "new"), *chosen, *common]) == 0
    return tuple(json.loads((folder / name / "metrics.json").read_text()) for name in ("clik", "new"))


def assert_tracks_like_clik(new: dict, clik: dict, *, error: float, rel: float, also: tuple[str, ...] = ()) -> None:
    """The metrics of :func:`run_beside_clik`: the circle tracked (CLIK here: 1.8e-10 m), the largest error CLIK's
    within ``error`` [m], the travels (and the metrics ``also``) CLIK's within ``rel``."""
    assert new["max_position_error"] < 1e-9
    assert new["max_position_error"] == pytest.approx(clik["max_position_error"], rel=0, abs=error)
    for name in ("arm_travel", "vehicle_travel", *also):
        assert new[name] == pytest.approx(clik[name], rel=rel), name


def xiang_eq6(theta: np.ndarray) -> pin.SE3:
    """0T5 of xiang2019 eq. 6, lengths converted from mm to m."""
    t1, t2, t3, t4 = theta
    c1, s1 = np.cos(t1), np.sin(t1)
    c2, s2 = np.cos(t2), np.sin(t2)
    c23, s23 = np.cos(t2 + t3), np.sin(t2 + t3)
    c234, s234 = np.cos(t2 + t3 + t4), np.sin(t2 + t3 + t4)
    reach = 0.080 + 0.370 * c2 + 0.308 * c234 + 0.220 * c23
    rotation = np.array([
        [c1 * c234, -c1 * s234, -s1],
        [s1 * c234, -s1 * s234, c1],
        [-s234, -c234, 0.0],
    ])
    position = np.array([c1 * reach, s1 * reach, -0.370 * s2 - 0.220 * s23 - 0.308 * s234])
    return pin.SE3(rotation, position)


# ------------------------------------------------------------------ hangs fail, they do not hang the suite
@contextlib.contextmanager
def deadline(seconds: float):
    """Raise TimeoutError in the block after ``seconds`` [s] (SIGALRM: a Python loop that never ends, or a Python
    ``open`` of a FIFO that never gets a writer, fails the test instead of hanging the suite)."""
    def expire(*_):
        raise TimeoutError(f"still running after {seconds} s")
    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


# ------------------------------------------------------------------ child processes of `uvms`
def uvms_command(*args: str) -> list[str]:
    """The command line of ``uvms ARGS`` in this interpreter."""
    return [sys.executable, "-m", "uvms.cli", *args]


def wait_for(condition, timeout: float = 120.0, process: subprocess.Popen | None = None):
    """Poll ``condition`` until it returns something true; fail if the process ends first or on timeout [s]."""
    started = time.monotonic()
    while time.monotonic() - started < timeout:
        found = condition()
        if found:
            return found
        if process is not None and process.poll() is not None:
            pytest.fail(f"the child ended ({process.returncode}) before the condition: {process.stderr.read()}")
        time.sleep(0.05)
    pytest.fail("timed out")


def signal_a_running_sweep(folder: Path, grid: str, sig: int, check=lambda child: None) -> tuple[subprocess.Popen, str]:
    """Start ``uvms sweep`` of the hoang2011 scenario over ``grid`` on 2 jobs into ``folder``, wait until a point is
    under way (its temporary folder inside the sweep's), run ``check(child)``, send ``sig``: (the child, its stderr).
    The child's process group is killed if it outlives this."""
    from uvms.io import outputs

    child = subprocess.Popen(uvms_command("sweep", str(SCENARIOS / "hoang2011_w1.toml"), "--grid", grid, "--jobs", "2",
                                          "--out", str(folder), "--quiet"), stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        wait_for(lambda: list(folder.parent.glob(f".sweep{outputs.TEMPORARY_MARK}*/.point_*{outputs.TEMPORARY_MARK}*")),
                 process=child)
        check(child)
        child.send_signal(sig)
        _, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
            child.communicate()
    return child, err


#: The fixture workspace of ROS packages: a vehicle package including an arm package by $(find) (tests/fixtures/ros_ws).
ROS_WORKSPACE = ROOT / "tests" / "fixtures" / "ros_ws" / "src"
#: A short run of that vehicle, whose ``[model]`` section ends with ``{package_path}`` (a line or nothing).
ROS_SHORT_RUN = """
[model]
path = "vehicle.urdf.xacro"
{package_path}

[task]
frame = "ee"
axes = ["x", "y", "z"]

[trajectory]
type = "line"
end_offset = [0.0, 0.05, 0.0]
duration = 0.4

[initial]
base = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
arm = [0.3, -0.7]

[simulation]
dt = 0.1

[outputs]
figures = false
"""


def yz_circle(folder: Path, axes: list[str]) -> Path:
    """A scenario file: a 5 cm circle in the world's y-z plane, driven by the bluerov2_alpha5 end effector on the
    task ``axes`` (kinematic, 4 s, figures of the run under test)."""
    path = folder / f"yz_{''.join(axes)}.toml"
    path.write_text(f"""
[model]
path = "bluerov2_alpha5"
[task]
axes = {json.dumps(axes)}
[trajectory]
type = "circle"
center_offset = [0.0, 0.0, 0.05]
normal = [1.0, 0.0, 0.0]
law = "quintic"
duration = 4.0
[initial]
arm = [3.0, 1.5, 1.5, 3.0, 0.005]
[solver]
gain = 5.0
[simulation]
dt = 0.02
""")
    return path


#: The excitation logs of the identification tests (uvms.scenario.excitation): multi-sine RMS body wrench
#: [N, N m] per axis, arm joint amplitudes [rad] (None: held), duration [s], step [s].
EXCITATIONS = {
    "held": ((20.0, 20.0, 30.0, 0.6, 0.6, 1.5), None, 60.0, 0.02),
    "arm": ((20.0, 20.0, 30.0, 0.6, 0.6, 1.5), (0.4, 0.3, 0.3, 0.4, 0.0), 60.0, 0.02),
    "heave_pitch": ((0.0, 0.0, 30.0, 0.0, 0.6, 0.0), None, 30.0, 0.02),
}
#: The arm's start [rad, m]: forward and down; in the vehicle's x-z plane for the heave-pitch log (E = pi), so that
#: nothing drives sway, roll or yaw there.
ARM_START = {"held": (3.0, 1.8, 1.8, 1.0, 0.0), "arm": (3.0, 1.8, 1.8, 1.0, 0.0),
             "heave_pitch": (np.pi, 1.8, 1.8, 0.0, 0.0)}


@functools.lru_cache(maxsize=None)
def excitation(kind: str):
    """(run, log) of the BlueROV2 + Alpha 5 (its own hydrodynamics, the truth) under an excitation of
    :data:`EXCITATIONS`, from 5 m deep with the arm forward (simulated once per test process)."""
    from uvms.scenario.excitation import excitation_run, log_of_run, multisine

    robot = shipped("bluerov2_alpha5")
    amplitudes, arm, duration, dt = EXCITATIONS[kind]
    q0 = pin.neutral(robot.model)
    q0[2] = -5.0
    q0[7:12] = ARM_START[kind]
    run, _ = excitation_run(robot, multisine(np.array(amplitudes)), q0, duration, dt,
                            arm_amplitudes=None if arm is None else np.array(arm))
    return run, log_of_run(robot, run, f"excitation {kind}")


#: Fresh water's density [kg/m^3] of the small hull models below.
HULL_RHO = 1000.0


def body_urdf(mass=10.0, volume=None, cob_z=0.0, added="", linear="", quadratic="", extra_link="", kind="fossen"):
    """One floating hull (mass [kg], inertia diag(0.3, 0.4, 0.5)) with a uuv_simulator block in fresh water."""
    volume = mass / HULL_RHO if volume is None else volume
    def tag(name, text):
        return f"<{name}>{text}</{name}>" if text else ""
    return f"""<robot name="hull">
      <link name="world"/>
      <joint name="base_joint" type="floating"><parent link="world"/><child link="hull"/></joint>
      <link name="hull"><inertial><mass value="{mass}"/>
        <inertia ixx="0.3" iyy="0.4" izz="0.5" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <gazebo><plugin name="uuv_plugin" filename="libuuv_underwater_object_ros_plugin.so">
        <fluid_density>{HULL_RHO}</fluid_density>
        <link name="hull">
          <volume>{volume}</volume>
          <center_of_buoyancy>0 0 {cob_z}</center_of_buoyancy>
          <hydrodynamic_model><type>{kind}</type>{tag("added_mass", added)}{tag("linear_damping", linear)}
            {tag("quadratic_damping", quadratic)}</hydrodynamic_model>
        </link>{extra_link}
      </plugin></gazebo></robot>"""
