"""Property-based tests: random valid URDF trees load with consistent kinematics; solvers never fake success;
random broken trees are refused with one line, at once."""

from __future__ import annotations

import re
import subprocess
import time

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import uvms
from uvms.robot.limits import Limit

from conftest import deadline, finite_difference_jacobian, uvms_command

finite = st.floats(-1.0, 1.0, allow_nan=False)
unit_axis = st.tuples(finite, finite, finite).filter(lambda v: np.linalg.norm(v) > 0.2).map(
    lambda v: tuple(float(x) for x in np.asarray(v) / np.linalg.norm(v)))
KINDS = ("revolute", "prismatic", "continuous", "fixed")


@st.composite
def urdf_trees(draw):
    """A random tree: 1-6 moving or fixed joints, each child hung on any earlier link; floating, planar or fixed
    root."""
    count = draw(st.integers(1, 6))
    links, joints = ["base"], []
    for index in range(count):
        parent = draw(st.sampled_from(links))
        kind = draw(st.sampled_from(KINDS))
        axis = draw(unit_axis)
        xyz = draw(st.tuples(finite, finite, finite))
        rpy = draw(st.tuples(finite, finite, finite))
        lower = draw(st.floats(-2.0, 0.0))
        joints.append((f"j{index}", kind, parent, f"l{index}", axis, xyz, rpy, lower,
                       lower + draw(st.floats(0.1, 3.0))))
        links.append(f"l{index}")
    root = draw(st.sampled_from(("floating", "planar", "fixed")))
    masses = draw(st.lists(st.floats(0.1, 10.0), min_size=len(links), max_size=len(links)))
    body = []
    for link, mass in zip(links, masses):
        if link == "base" and root == "fixed":  # a massless root link: an arm on a table (uvms.load's base rule)
            body.append('<link name="base"/>')
            continue
        body.append(f'<link name="{link}"><inertial><mass value="{mass}"/>'
                    f'<inertia ixx="{mass}" iyy="{mass}" izz="{mass}" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    for name, kind, parent, child, axis, xyz, rpy, lower, upper in joints:
        limit = (f'<limit lower="{lower}" upper="{upper}" effort="1" velocity="1"/>'
                 if kind in ("revolute", "prismatic") else "")
        body.append(f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                    f'<origin xyz="{" ".join(map(repr, xyz))}" rpy="{" ".join(map(repr, rpy))}"/>'
                    f'<axis xyz="{" ".join(map(repr, axis))}"/>{limit}</joint>')
    if root != "fixed":
        body.insert(0, '<link name="world"/>')
        body.append(f'<joint name="base_joint" type="{root}"><parent link="world"/><child link="base"/></joint>')
    return f'<robot name="fuzz">{"".join(body)}</robot>', root, links[-1]


def load_or_refuse(text: str, leaf: str) -> uvms.Robot | None:
    """The robot, or None after checking that a tree without any degree of freedom is refused."""
    if 'type="fixed"' in text and all(kind not in text for kind in ("revolute", "prismatic", "continuous",
                                                                    'type="floating"', 'type="planar"')):
        with pytest.raises(uvms.errors.ModelCheckError, match="no degree of freedom"):
            uvms.load(text, ee=leaf)
        return None
    return uvms.load(text, ee=leaf)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tree=urdf_trees(), seed=st.integers(0, 2**31 - 1))
def test_random_trees_load_with_consistent_kinematics(tree, seed):
    text, root, leaf = tree
    robot = load_or_refuse(text, leaf)
    if robot is None:
        return
    assert robot.base_type == root
    q = robot.random_configuration(np.random.default_rng(seed))
    jacobian = robot.jacobian(q, leaf)
    assert np.all(np.isfinite(jacobian))
    assert np.allclose(jacobian, finite_difference_jacobian(robot, q, leaf), atol=1e-6)
    assert np.allclose(robot.fk(q, leaf).rotation @ robot.fk(q, leaf).rotation.T, np.eye(3), atol=1e-12)


#: Found by hypothesis in CI: one joint, held at its limit by the clamping, left no column to solve (IndexError).
#: Its root link is massless, so by uvms.load's base rule it stays a fixed-base arm.
ONE_HELD_JOINT = ('<robot name="fuzz"><link name="base"/><link '
                  'name="l0"><inertial><mass value="1.0"/><inertia ixx="1.0" iyy="1.0'
                  '" izz="1.0" ixy="0" ixz="0" iyz="0"/></inertial></link><joint '
                  'name="j0" type="revolute"><parent link="base"/><'
                  'child link="l0"/><origin xyz="0.0 0.0 0.0" rpy="0.0 0.0 '
                  '0.0"/><axis xyz="0.0 0.0 1.0"/><limit lower="0.0" uppe'
                  'r="1.0" effort="1" velocity="1"/></joint></robot>')


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tree=urdf_trees(), seed=st.integers(0, 2**31 - 1))
@example(tree=(ONE_HELD_JOINT, "fixed", "l0"), seed=0)
def test_ik_never_reports_a_false_success(tree, seed):
    """Pose IK's success flag is the truth; one Limit keeps IK projection and CLIK clamping inside the joint limits."""
    text, _, leaf = tree
    robot = load_or_refuse(text, leaf)
    if robot is None:
        return
    rng = np.random.default_rng(seed)
    reachable = robot.fk(robot.random_configuration(rng), leaf)
    unreachable = pin.SE3(reachable.rotation, reachable.translation + [50.0, 0.0, 0.0])
    for target in (reachable, unreachable):
        result = uvms.solve_ik(robot, target, frame=leaf, restarts=2, max_iterations=60, rng=seed)
        assert np.all(np.isfinite(result.q)) and np.isfinite(result.error)
        error = np.concatenate([target.translation - robot.fk(result.q, leaf).translation,
                                pin.log3(target.rotation @ robot.fk(result.q, leaf).rotation.T)])
        rows = uvms.robot.kinematics.axis_rows(uvms.robot.robot.DEFAULT_AXES[robot.base_type])
        axes_error = np.linalg.norm(error[rows])
        assert result.success == (axes_error <= 1e-10)  # the flag is the truth
        lower, upper = robot.arm_limits
        arm = robot.arm_configuration(result.q)
        assert np.all(arm >= lower - 1e-12) and np.all(arm <= upper + 1e-12)
    assert_limit_projection_and_clamping(robot, leaf, rng)


def assert_limit_projection_and_clamping(robot: uvms.Robot, leaf: str, rng: np.random.Generator) -> None:
    """Limit.project equals the clipping of pose IK before the Limit concept; CLIK clamping keeps q inside."""
    limit = Limit.joint_positions(robot)
    q = robot.random_configuration(rng)
    pushed = q.copy()
    held = limit.q_index[limit.q_index >= 0]
    pushed[held] += rng.normal(scale=3.0, size=held.size)
    projected = limit.project(pushed)
    assert limit.contains(robot.arm_configuration(projected))
    before = pushed.copy()  # every arm entry of q clipped to the model's limits
    arm = slice(robot.nq_vehicle, robot.nq)
    before[arm] = np.clip(before[arm], robot.model.lowerPositionLimit[arm], robot.model.upperPositionLimit[arm])
    assert np.array_equal(projected, before)
    task = uvms.FrameTask(robot, leaf, target=robot.fk(robot.random_configuration(rng), leaf))
    solver = uvms.CLIKSolver(robot, task, gain=5.0, damping=1e-3, dt=0.5, enforce_limits=True)
    configuration = uvms.Configuration(robot, q)
    for _ in range(5):
        solver.step(configuration, 0.5)
        assert np.all(np.isfinite(configuration.q))
        q = configuration.q
        assert limit.contains(robot.arm_configuration(q))


# ------------------------------------------------------------------ broken trees
#: How a URDF's links can fail to be one tree (each drawn by malformed_trees).
DEFECTS = ("cycle beside the root", "cycle through the root", "self-parent", "two roots", "missing link",
           "two parents", "empty robot")
MASSIVE = '<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'


def tree_text(links: list[str], edges: list[tuple[str, str]]) -> str:
    """A URDF of massive links joined by revolute joints, one per (parent, child) edge."""
    body = [f'<link name="{link}">{MASSIVE}</link>' for link in links]
    body += [f'<joint name="j{index}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
             '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
             for index, (parent, child) in enumerate(edges)]
    return f'<robot name="broken">{"".join(body)}</robot>'


@st.composite
def malformed_trees(draw):
    """(URDF text, defect): a random tree of 1-6 links broken one way; cycles of 2-5 links."""
    kind = draw(st.sampled_from(DEFECTS))
    if kind == "empty robot":
        return '<robot name="broken"/>', kind
    links = ["base"] + [f"l{index}" for index in range(draw(st.integers(1, 5)))]
    edges = [(draw(st.sampled_from(links[:index])), link) for index, link in enumerate(links) if index]
    if kind in ("cycle beside the root", "self-parent"):  # one root, and links no walk from it reaches
        ring = [f"c{index}" for index in range(1 if kind == "self-parent" else draw(st.integers(2, 5)))]
        links += ring
        edges += [(link, ring[(index + 1) % len(ring)]) for index, link in enumerate(ring)]
    elif kind == "cycle through the root":  # the root hangs below one of its descendants: no root at all
        edges.append((draw(st.sampled_from(links[1:])), "base"))
    elif kind == "two roots":
        links.append("loose")
    elif kind == "missing link":
        edge = draw(st.sampled_from([("base", "ghost"), ("ghost", links[-1])]))
        edges = [e for e in edges if e[1] != edge[1]] + [edge]
    elif kind == "two parents":
        child = draw(st.sampled_from(links[1:]))
        edges.append((draw(st.sampled_from([link for link in links if link != child])), child))
    return tree_text(links, edges), kind


@settings(max_examples=60, deadline=None)
@given(broken=malformed_trees())
def test_broken_trees_are_refused_at_once(broken):
    text, kind = broken
    started = time.perf_counter()
    with deadline(2.0), pytest.raises(uvms.UVMSError) as refused:
        uvms.load(text)
    assert time.perf_counter() - started < 1.0, kind
    assert len(str(refused.value).splitlines()) == 1


#: One broken tree of each kind, and what the refusal says.
BROKEN = {
    "cycle beside the root": (tree_text(["r", "a", "b", "c"], [("a", "b"), ("b", "c"), ("c", "a")]),
                              "the joints form a cycle (a -> b -> c -> a)"),
    "cycle through the root": (tree_text(["a", "b"], [("a", "b"), ("b", "a")]), "the joints form a cycle"),
    "self-parent": (tree_text(["r", "a"], [("a", "a")]), "the joints form a cycle (a -> a)"),
    "two roots": (tree_text(["r", "a", "b"], [("r", "a")]), "2 roots (r, b)"),
    "missing link": (tree_text(["r"], [("r", "ghost")]), "names link 'ghost', which is not defined"),
    "two parents": (tree_text(["r", "a", "b"], [("r", "a"), ("r", "b"), ("a", "b")]), "child of two joints"),
    "empty robot": ('<robot name="broken"/>', "has no <link>"),
}


@pytest.mark.parametrize("kind", DEFECTS)
def test_broken_trees_give_one_line_from_the_cli(kind, tmp_path):
    text, says = BROKEN[kind]
    with pytest.raises(uvms.errors.ModelCheckError, match=re.escape(says)):
        uvms.load(text)
    path = tmp_path / "broken.urdf"
    path.write_text(text)
    done = subprocess.run(uvms_command("info", str(path)), capture_output=True, text=True, timeout=20,
                          check=False)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and says in done.stderr, done.stderr
