"""The Limit concept (uvms.robot.limits): one reading of the joint limits for the potential, CLIK clamping, the
set-based objectives, IK projection and optimizer bounds."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.errors import LimitError
from uvms.robot.limits import Limit
from uvms.solvers.ik import project_to_limits
from uvms.tasks.objectives import JointLimits, JointVelocityLimits

from conftest import shipped

CONTINUOUS_ARM = """<robot name="mixed">
  <link name="world"/>
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="root" type="floating"><parent link="world"/><child link="base"/></joint>
  <link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="ee">
    <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="spin" type="continuous"><parent link="base"/><child link="a"/><origin xyz="0.1 0 0"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="lift" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.1" upper="0.3" effort="1" velocity="0.5"/></joint>
  <joint name="tilt" type="revolute"><parent link="b"/><child link="ee"/><origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="2" effort="1" velocity="0"/></joint>
</robot>"""


@pytest.mark.parametrize("name", ["hoang2011", "xiang2019", "bluerov2_alpha5"])
def test_position_limits_are_the_models(name):
    robot = shipped(name)
    limit = Limit.joint_positions(robot)
    lower, upper = robot.arm_limits
    assert limit.kind == "position" and limit.size == robot.n_arm
    assert np.array_equal(limit.lower, lower) and np.array_equal(limit.upper, upper)
    assert limit.names == tuple(robot.arm_joint_names)
    arm_q = slice(robot.nq_vehicle, robot.nq)
    assert np.array_equal(limit.q_index, np.arange(robot.nq)[arm_q])  # revolute/prismatic: one q entry each
    assert limit.bounds() == [(lo, hi) for lo, hi in zip(lower, upper)]


def test_continuous_joints_and_velocity_limits():
    robot = uvms.load(CONTINUOUS_ARM)
    limit = Limit.joint_positions(robot)
    assert limit.names == ("spin", "lift", "tilt")
    assert limit.q_index.tolist() == [-1, 9, 10]  # spin is (cos, sin) at q[7:9]
    assert limit.bounded.tolist() == [False, True, True]
    assert limit.bounds() == [(None, None), (-0.1, 0.3), (-1.0, 2.0)]
    assert limit.middle == pytest.approx([0.0, 0.1, 0.5]) and limit.span == pytest.approx([1.0, 0.4, 3.0])
    velocity = Limit.joint_velocities(robot)
    assert velocity.kind == "velocity"
    assert velocity.upper.tolist() == [np.inf, 0.5, np.inf]  # no limit tag, 0.5, and the placeholder 0
    assert np.array_equal(velocity.lower, -velocity.upper)
    v = np.array([3.0, -1.0, 0.2])
    scaled = velocity.scale_into(v)
    assert scaled == pytest.approx(0.5 * v) and velocity.contains(scaled)  # direction kept
    assert velocity.clamp(v).tolist() == [3.0, -0.5, 0.2]
    assert np.array_equal(velocity.scale_into(0.1 * v), 0.1 * v)


def test_project_clips_what_q_holds_and_leaves_rotations_alone(rng):
    robot = uvms.load(CONTINUOUS_ARM)
    limit = Limit.joint_positions(robot)
    for _ in range(20):
        q = robot.random_configuration(rng)
        q[9:] += rng.normal(scale=3.0, size=2)
        projected = limit.project(q)
        assert limit.contains(robot.arm_configuration(projected))
        assert np.array_equal(projected[:9], q[:9])  # vehicle pose and the (cos, sin) of the continuous joint
        before = q.copy()  # what pose IK did before the Limit concept: clip every arm entry of q
        before[7:] = np.clip(before[7:], robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:])
        assert np.array_equal(projected, before)
        assert np.array_equal(project_to_limits(robot, q), projected)


def test_margin_and_bad_limits():
    robot = shipped("hoang2011")
    inner = Limit.joint_positions(robot, margin=0.1)
    assert inner.lower == pytest.approx([0.1, -1.5 * np.pi + 0.1, -1.5 * np.pi + 0.1])
    assert inner.upper == pytest.approx([1.5 * np.pi - 0.1, 1.5 * np.pi - 0.1, 1.5 * np.pi - 0.1])
    assert Limit.joint_positions(robot, margin=0.0).lower.tolist() == robot.arm_limits[0].tolist()
    with pytest.raises(LimitError, match="no room"):
        Limit.joint_positions(robot, margin=3.0)
    with pytest.raises(LimitError, match="margin"):
        Limit.joint_positions(robot, margin=-0.1)
    with pytest.raises(LimitError, match="lower <= upper"):
        Limit([0.0, 1.0], [1.0, 0.5])
    with pytest.raises(LimitError, match="lower <= upper"):
        Limit([np.nan], [1.0])
    with pytest.raises(LimitError, match="valid: position, velocity"):
        Limit([0.0], [1.0], kind="torque")
    padded = inner.after_unbounded(3)
    assert padded.size == 6 and padded.bounds()[:3] == [(None, None)] * 3 and padded.names[3:] == inner.names
    values = np.array([-1.0, 0.0, 9.0, -0.05, 0.0, 4.8])
    assert padded.violated(values).tolist() == [False, False, False, True, False, True]
    assert padded.crossed_bound(values)[[3, 5]] == pytest.approx([0.1, 1.5 * np.pi - 0.1])


def test_every_user_reads_the_same_limit():
    """The potential, CLIK clamping and the initial configuration all take a Limit, e.g. one with a margin."""
    robot = shipped("hoang2011")
    inner = Limit.joint_positions(robot, margin=0.2)
    potential = uvms.tasks.MidRangePotential(robot, limit=inner)
    assert potential.limit is inner
    assert potential.middle == pytest.approx(inner.middle) and potential.range == pytest.approx(inner.span)
    assert uvms.tasks.MidRangePotential(robot).limit.lower.tolist() == robot.arm_limits[0].tolist()
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0, 0, 0, 0, 0, 0])
    q = robot.configuration(arm=[0.3, 4.2, -4.2])  # inside the margin
    clamped_any = False
    solver = uvms.CLIKSolver(robot, task, gain=5.0, weights=[100, 100, 100, 1, 1, 1], dt=0.1, enforce_limits=True,
                             limit=inner)
    configuration = uvms.Configuration(robot, q)
    for _ in range(100):
        result = solver.step(configuration, 0.1)
        q = configuration.q
        assert inner.contains(robot.arm_configuration(q))
        clamped_any |= bool(result.limits_active)
    assert clamped_any
    with pytest.raises(LimitError, match="enforce_limits needs position limits of the 3 arm"):
        uvms.CLIKSolver(robot, task, dt=0.1, enforce_limits=True, limit=Limit([0.0], [1.0]))
    with pytest.raises(uvms.UVMSError, match="position limits of the 3 arm"):
        uvms.tasks.MidRangePotential(robot, limit=Limit.joint_velocities(robot))
    # the initial configuration inside a box that excludes the paper's optimum q1 = 3 pi / 4
    box = Limit(robot.arm_limits[0], [0.5 * np.pi, 1.5 * np.pi, 1.5 * np.pi])
    target = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0, -2, 0, 0, 0, 1.0])
    result = uvms.solvers.initial_configuration(robot, target, limit=box)
    assert result.success and box.contains(robot.arm_configuration(result.q))
    assert robot.arm_configuration(result.q)[0] == pytest.approx(0.5 * np.pi, abs=1e-6)  # pressed on the new bound


def test_pose_ik_projects_into_the_limits_it_reads():
    arm = uvms.load(uvms.model.example_robot_urdf("ur5"))  # fixed base: an unreachable target pulls every joint
    limit = Limit.joint_positions(arm)
    for target in ([3.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, -2.0, 1.0, 0.0, 1.0, 0.0]):
        result = uvms.solve_ik(arm, target, restarts=2, max_iterations=30)
        assert not result.success and limit.contains(arm.arm_configuration(result.q))


def test_a_custom_limit_moves_the_potential_the_objective_and_the_clamping_alike():
    """One Limit, three uses: the potential's middle and range, the objective's rows and valid set, CLIK's clamping."""
    robot = shipped("hoang2011")
    model = Limit.joint_positions(robot)
    custom = Limit([0.2, -2.0, -1.0], [2.0, 2.0, 1.5], model.names, model.q_index)
    potential = uvms.tasks.MidRangePotential(robot, limit=custom)
    assert potential.middle == pytest.approx([1.1, 0.0, 0.25]) and potential.range == pytest.approx([1.8, 4.0, 2.5])
    assert potential.value(robot.configuration(arm=[2.0, 0.0, 0.25])) == pytest.approx(0.125)  # 1/2 (0.9 / 1.8)^2
    objective = JointLimits(robot, limit=custom, margin=0.1, band=0.2)
    assert objective.limit.lower.tolist() == custom.lower.tolist() and objective.hard_upper.tolist() == [2.0, 2.0, 1.5]
    assert objective.lower == pytest.approx([0.3, -1.9, -0.9]) and objective.upper == pytest.approx([1.9, 1.9, 1.4])
    assert np.array_equal(objective.lower, custom.shrink(0.1).lower)  # the objective's valid set is Limit.shrink's
    rows = objective.rows(uvms.Configuration(robot, robot.configuration(arm=[0.3, 0.0, 0.25])))
    assert rows.activation.tolist() == [1.0, 0.0, 0.0] and rows.reference[0] == pytest.approx(0.2)  # gain (0.5 - 0.3)
    q = robot.configuration(arm=[1.9, 0.0, 0.0])
    task = uvms.JointTask(robot, {"q1": 3.0})  # asks 1.1 rad/s: 0.11 rad in a step of 0.1 s
    free = uvms.CLIKSolver(robot, task, dt=0.1, enforce_limits=True).velocity(uvms.Configuration(robot, q))
    clamped = uvms.CLIKSolver(robot, task, dt=0.1, enforce_limits=True, limit=custom).velocity(
        uvms.Configuration(robot, q))
    assert free.v[robot.n_vehicle] == pytest.approx(1.1) and not free.limits_active  # the model's bound: 3 pi / 2
    assert clamped.v[robot.n_vehicle] == pytest.approx(1.0) and clamped.limits_active == ("q1",)  # held at 2.0
    # the margins of the objective are those of a Limit, one number or {joint: margin}
    per_joint = JointLimits(robot, margin={"q2": 0.3})
    assert np.array_equal(per_joint.lower, model.shrink({"q2": 0.3}).lower)
    assert per_joint.lower == pytest.approx([0.0, -1.5 * np.pi + 0.3, -1.5 * np.pi])
    assert per_joint.margin.tolist() == [0.0, 0.3, 0.0]
    with pytest.raises(uvms.UVMSError, match="close names: q2"):
        JointLimits(robot, margin={"q22": 0.3})
    with pytest.raises(LimitError, match="no room inside the limits of q1 \\[0.2, 2\\]"):
        JointLimits(robot, limit=custom, margin=0.95)
    for build in (uvms.tasks.MidRangePotential, JointLimits):
        with pytest.raises(LimitError, match="needs position limits of the 3 arm coordinates, got 3 velocity"):
            build(robot, limit=Limit.joint_velocities(robot))


def test_the_velocity_objective_reads_a_velocity_limit():
    robot = uvms.load(CONTINUOUS_ARM)
    model = Limit.joint_velocities(robot)
    default = JointVelocityLimits(robot)
    assert default.limit.upper.tolist() == model.upper.tolist() == [np.inf, 0.5, np.inf]
    assert default.maximum.tolist() == [np.inf] * 6 + [np.inf, 0.5, np.inf]
    custom = Limit([-0.2, -0.3, -0.4], [0.2, 0.3, 0.4], model.names, kind="velocity")
    assert JointVelocityLimits(robot, limit=custom).maximum[6:].tolist() == [0.2, 0.3, 0.4]
    assert JointVelocityLimits(robot, 0.7).limit.upper.tolist() == [0.7, 0.7, 0.7]
    assert Limit.joint_velocities(robot, {"tilt": 0.25}).upper.tolist() == [np.inf, np.inf, 0.25]
    assert Limit.joint_velocities(robot, [1.0, 2.0, 3.0]).lower.tolist() == [-1.0, -2.0, -3.0]
    with pytest.raises(LimitError, match="numbers > 0"):
        Limit.joint_velocities(robot, 0.0)
    with pytest.raises(LimitError, match="one number or 3"):
        Limit.joint_velocities(robot, [1.0, 2.0])
    with pytest.raises(uvms.UVMSError, match="close names: tilt"):
        Limit.joint_velocities(robot, {"tlt": 1.0})
    with pytest.raises(LimitError, match="not both"):
        JointVelocityLimits(robot, 0.7, limit=custom)
    with pytest.raises(LimitError, match="symmetric"):
        JointVelocityLimits(robot, limit=Limit([-0.1, -0.3, -0.4], [0.2, 0.3, 0.4], model.names, kind="velocity"))
    with pytest.raises(LimitError, match="needs velocity limits of the 3 arm coordinates, got 3 position"):
        JointVelocityLimits(robot, limit=Limit.joint_positions(robot))


def test_the_model_limits_are_one_object_read_by_every_user():
    """One source of the model's bounds (Limit.joint_positions/joint_velocities): the potential, CLIK's clamping, the
    objectives and the IK read it; CLIK clamps to its potential's box unless told otherwise, and refuses two different
    boxes."""
    robot = shipped("hoang2011")
    model = Limit.joint_positions(robot)
    assert model.lower.tolist() == robot.arm_limits[0].tolist() and model.upper.tolist() == robot.arm_limits[1].tolist()
    assert uvms.tasks.MidRangePotential(robot).limit.upper.tolist() == model.upper.tolist()
    assert JointLimits(robot).limit.lower.tolist() == model.lower.tolist()
    with pytest.raises(ValueError, match="read-only"):
        model.lower[0] = 1.0  # shared: never changed in place
    custom = Limit([0.2, -2.0, -1.0], [2.0, 2.0, 1.5], model.names, model.q_index)
    task = uvms.JointTask(robot, {"q1": 3.0})
    q = uvms.Configuration(robot, robot.configuration(arm=[1.9, 0.0, 0.0]))
    potential = uvms.tasks.MidRangePotential(robot, limit=custom)
    solver = uvms.CLIKSolver(robot, task, dt=0.1, enforce_limits=True, potential=potential, alpha=1e-9)
    assert solver.limit is custom and solver.velocity(q).limits_active == ("q1",)  # held at the potential's 2.0
    with pytest.raises(LimitError, match="read one Limit"):
        uvms.CLIKSolver(robot, task, dt=0.1, enforce_limits=True, potential=potential, limit=model)
    assert Limit.joint_positions(robot).excess(np.array([[-0.5, 0.0, 5.0]])).tolist() == \
        [[0.5, 0.0, pytest.approx(5.0 - 1.5 * np.pi)]]
    vehicle = uvms.tasks.VehicleVelocityLimits(robot, [0.5, 0.2])
    assert vehicle.limit.upper.tolist() == [0.5, 0.5, 0.2] and vehicle.limit.names == robot.base.velocity_names


@pytest.mark.parametrize("model", ["hoang2011", "continuous"])
def test_arm_values_of_rows_are_those_of_each_row(model, rng):
    """A run's rows (N, nq) at once: the values of one q at a time (continuous joints: their angles)."""
    robot = shipped(model) if model != "continuous" else uvms.load(CONTINUOUS_ARM)
    rows = np.array([robot.configuration(arm=rng.uniform(-1.0, 1.0, robot.n_arm)) for _ in range(5)])
    values = robot.arm_values(rows)
    assert values.shape == (5, robot.n_arm)
    assert np.array_equal(values, np.array([robot.arm_values(q) for q in rows]))
