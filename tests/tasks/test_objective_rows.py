"""Objectives' rows written in place into a solver's stacks, and the hierarchy's stacks: the numbers of the
formulas as they were written before (per objective, per level, stacked after)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.robot.configuration import Configuration
from uvms.tasks.objectives import FrameBox, JointLimits, PlaneClearance, VehicleAttitude


@pytest.fixture(scope="module")
def robot():
    return uvms.load("bluerov2_alpha5")


def tilted(robot, rng, tilt_deg=6.0):
    """A configuration with the vehicle tilted up to ``tilt_deg`` and the arm anywhere in its limits."""
    tilt, direction = np.radians(tilt_deg) * np.sqrt(rng.uniform()), rng.uniform(-np.pi, np.pi)
    limit = uvms.Limit.joint_positions(robot)
    return robot.configuration(base=[0, 0, -5.3 + rng.uniform(-0.3, 0.3), tilt * np.cos(direction),
                                     tilt * np.sin(direction), rng.uniform(-3, 3)],
                               arm=rng.uniform(limit.lower, limit.upper))


def old_tilt_rows(objective, state):
    """The vehicle attitude's value and row as VehicleAttitude.value_jacobian computed them in numpy."""
    x, y, z = state.pose(objective.frame_id).rotation[:, 2].tolist()
    tilt = np.array([np.arccos(min(max(z, -1.0), 1.0))])
    axis = np.array([y, -x, 0.0])
    length = math.sqrt(axis.dot(axis))
    if length < 1e-9:
        return tilt, np.zeros((1, state.robot.nv))
    axis /= length
    return tilt, -(axis @ state.jacobian(objective.frame_id)[3:])[None, :]


def old_clearance_rows(objective, state):
    """A plane clearance's value and row as PlaneClearance.value_jacobian computed them in numpy."""
    return (np.array([objective.normal @ (state.pose(objective.frame_id).translation - objective.point)]),
            (objective.normal @ state.jacobian(objective.frame_id)[:3])[None, :])


def assert_same(actual, expected):
    np.testing.assert_allclose(actual, expected, rtol=1e-15, atol=1e-300)


def test_rows_into_write_the_numbers_of_the_numpy_formulas_into_views_of_a_stack(robot):
    """Each kind's rows_into (compiled tilt and clearance, joint limits, and the generic copy of a frame box) writes
    its row, activation and reference at its place in a stack and returns rows whose arrays are those views; the
    values are those of the numpy formulas; at tilt 0 the tilt's row is 0."""
    rng = np.random.default_rng(46)
    objectives = [JointLimits(robot, margin={"alpha_axis_e": 0.05}, band=0.2),
                  VehicleAttitude(robot, 0.0873, band=0.035),
                  PlaneClearance(robot, "vehicle", [0, 0, -5.55], [0.1, 0.0, 1.0], min=0.5, band=0.1),
                  FrameBox(robot, lower=[-9, -9, -9], upper=[9, 9, -4.6], band=0.1)]
    old = {VehicleAttitude: old_tilt_rows, PlaneClearance: old_clearance_rows,
           JointLimits: lambda o, s: (s.q[o.q_index], o.jacobian(s)), FrameBox: lambda o, s: o.value_jacobian(s)}
    size = sum(objective.dim for objective in objectives)
    checked_active = 0
    for trial in range(40):
        q = tilted(robot, rng, 0.0 if trial == 0 else 6.0)
        state = Configuration(robot, q)
        jacobians, activations, references = np.full((size + 2, robot.nv), 7.0), np.full(size + 2, 7.0), \
            np.full(size + 2, 7.0)
        row = 1
        for objective in objectives:
            end = row + objective.dim
            rows = objective.rows_into(state, jacobians[row:end], activations[row:end], references[row:end])
            value, jacobian = old[type(objective)](objective, state)
            assert_same(rows.value, value)
            assert_same(jacobians[row:end], jacobian)
            assert_same(activations[row:end], objective.activation(value))
            assert_same(references[row:end], objective.reference(value))
            assert np.shares_memory(rows.jacobian, jacobians) and np.shares_memory(rows.activation, activations)
            assert np.shares_memory(rows.reference, references)
            assert rows.name == objective.name and rows.gain == objective.gain
            # the same numbers through rows() (what a recorder evaluates)
            alone = objective.rows(state)
            assert_same(alone.jacobian, jacobian) and assert_same(alone.activation, activations[row:end])
            checked_active += bool(np.any(rows.activation > 0))
            row = end
        if trial == 0:
            assert not np.any(jacobians[1 + objectives[0].dim])  # the level vehicle: no tilt gradient
        assert np.all(jacobians[0] == 7.0) and np.all(jacobians[-1] == 7.0)  # nothing written outside its rows
        assert activations[0] == 7.0 and references[-1] == 7.0
    assert checked_active > 10  # activations in and outside the bands were compared


def test_hierarchy_stacks_hold_each_levels_rows_and_stay_with_their_result(robot):
    """A hierarchy's stacks are every level's rows at the plan's offsets (the numbers each item gives alone: tasks'
    command xdot_d + K e, equality activations 1); its levels are views of them; a second evaluation writes new
    stacks, so a kept hierarchy's rows stay those of its own q."""
    from uvms.solvers.hierarchy import HierarchyPlan

    rng = np.random.default_rng(7)
    target = robot.fk(robot.random_configuration(rng))
    task = uvms.FrameTask(robot, target=target, axes=("x", "y", "z"))
    task.set_target_velocity(rng.normal(size=6))
    limits, attitude = JointLimits(robot, band=0.2), VehicleAttitude(robot, np.radians(5.0))
    clearance = PlaneClearance(robot, "vehicle", [0, 0, -5.55], [0, 0, 1], min=0.5, band=0.1)
    plan = HierarchyPlan(robot, [limits, [attitude, clearance], [task, clearance], task], gain=2.0)
    q1, q2 = tilted(robot, rng), tilted(robot, rng)
    first = plan.evaluate(Configuration(robot, q1))
    expected = []
    for items in ([limits], [attitude, clearance], [task, clearance], [task]):
        state = Configuration(robot, q1)
        for item in items:
            if item is task:
                jacobian, error, feedforward = task.terms(state)
                expected.append((jacobian, feedforward + 2.0 * error, np.ones(3)))
            else:
                rows = item.rows(state)
                expected.append((rows.jacobian, rows.reference, rows.activation))
    plan.evaluate(Configuration(robot, q2))  # another q: new stacks, the first kept
    assert_same(first.jacobians, np.vstack([block[0] for block in expected]))
    assert_same(first.references, np.concatenate([block[1] for block in expected]))
    assert_same(first.activations, np.concatenate([block[2] for block in expected]))
    assert first.solved is first.jacobians
    k = limits.dim
    assert plan.offsets.tolist() == [0, k, k + 2, k + 6, k + 9]
    levels = first.levels
    assert [level.equality for level in levels] == [False, False, False, True]
    assert np.shares_memory(levels[2].task_jacobian, first.jacobians)
    assert_same(levels[2].task_command, expected[3][1]) and assert_same(levels[2].jacobian[3:], expected[4][0])
    assert [rows.name for rows in levels[1].objectives] == [attitude.name, clearance.name]
    assert levels[0].task_error is None and levels[3].task_error.shape == (3,)


def test_objectives_read_their_frame_from_the_joint_kinematics_in_pinocchios_numbers(robot):
    """FrameReader: a frame's z axis and the tilt's and the clearances' rows formed from the joint kinematics (the
    joint's placement and data.J, what the step computes once) are, bit for bit, those of Pinocchio's frame pose and
    frame Jacobian (the path of a model with mimic joints), for frames placed in their joint with an offset (the jaws'
    end effector) and with a rotation (the arm's base)."""
    import copy

    from uvms.tasks.objectives.frames import FrameReader

    rotated = [frame.name for frame in robot.model.frames
               if frame.parentJoint > 0 and not np.allclose(frame.placement.rotation, np.eye(3))]
    assert "alpha_base_link" in rotated
    objectives = [VehicleAttitude(robot, 0.0873, band=0.035),
                  PlaneClearance(robot, "vehicle", [0, 0, -5.55], [0.1, 0.0, 1.0], min=0.5, band=0.1),
                  PlaneClearance(robot, "ee", [0.2, 0.1, -5.5], [0.3, -0.2, 1.0], min=0.1, band=0.5),
                  PlaneClearance(robot, "alpha_base_link", [0.0, 0.3, -5.2], [0.0, -1.0, 0.2], min=0.0, band=0.6)]
    framed = []  # the same objectives reading Pinocchio's frame pose and Jacobian
    for objective in objectives:
        other = copy.copy(objective)
        other._frame = copy.copy(objective._frame)
        other._frame.joint, other._frame.columns = None, np.arange(robot.nv, dtype=np.int64)
        framed.append(other)
    # a frame placed with a general rotation (the shipped ones turn about one axis: their z columns sum exactly)
    model = pin.Model(robot.model)
    tilted_frame = model.addFrame(pin.Frame("tilted", 5, pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.7, 1.1),
                                                                  np.array([0.1, -0.05, 0.2])), pin.FrameType.OP_FRAME))
    general = FrameReader(SimpleNamespace(model=model, mimic_joint_names=[], nv=model.nv), tilted_frame)
    data = model.createData()
    readers = [FrameReader(robot, robot.frame_id(name)) for name in ("alpha_base_link", "ee", rotated[-1])]
    rng = np.random.default_rng(146)
    active = 0
    for trial in range(300):
        q = tilted(robot, rng, 0.0 if trial == 0 else 40.0)
        for objective, other in zip(objectives, framed):
            rows, expected = objective.rows(Configuration(robot, q)), other.rows(Configuration(robot, q))
            for name in ("value", "jacobian", "activation", "reference"):
                assert getattr(rows, name).tobytes() == getattr(expected, name).tobytes(), (objective.name, name)
            active += bool(rows.activation[0] > 0.0)
        state = Configuration(robot, q)
        for reader in readers:
            assert reader.joint is not None
            assert reader.z_axis(state) == tuple(state.pose(reader.frame_id).rotation[:, 2].tolist())
        pin.forwardKinematics(model, data, q)
        placed = pin.updateFramePlacement(model, data, tilted_frame)
        assert general.z_axis(state) == tuple(placed.rotation[:, 2].tolist())
    assert active > 100  # rows inside and outside the bands were compared
