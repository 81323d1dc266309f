"""The collision objectives (uvms.tasks.objectives.collision, .obstacles): their rows are the nearest pairs' signed
distances and Jacobians; an obstacle's distance is that of its closed form; bad parameters are clear errors; inside
the set-based and QP hierarchies a floating box_arm whose straight CLIK path drives its jaw through its own vehicle
stays clear (distances recomputed from the recorded configurations)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms
from tests.conftest import ROOT
from uvms.errors import FrameNotFound, LinkNotFound, ObjectiveError
from uvms.model.collision import candidate_pairs, collision_geometry
from uvms.model.distances import PairDistances
from uvms.robot.configuration import Configuration
from uvms.solvers import CLIKSolver, HQPSolver, SetBasedSolver
from uvms.tasks.objectives import Obstacle, SelfCollision, inequalities_from_table
from uvms.tasks.objectives.collision import POINTS

BOX_ARM = Path(__file__).parents[1] / "fixtures" / "collision" / "box_arm.urdf"
#: The jaw's target under the vehicle's bow: the straight path from above the bow passes through the vehicle.
UNDER_THE_BOW = np.array([0.15, 0.0, -0.22])
#: Vehicle motion weighted 1000 times the arm's: the arm does the work (the vehicle could otherwise step aside).
ARM_FIRST = np.r_[np.full(6, 1000.0), np.ones(3)]


@pytest.fixture(scope="module")
def robot():
    with pytest.warns(uvms.errors.BaseGuessWarning):
        return uvms.load(BOX_ARM)


@pytest.fixture(scope="module")
def every_pair(robot):
    """All pairs on different, non-adjacent bodies: the independent oracle of the rows."""
    geometry = collision_geometry(robot)
    return PairDistances(robot.model, geometry, candidate_pairs(robot, geometry).pairs)


def random_state(robot, rng):
    base = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-1, 1, 3)), rng.uniform(-1, 1, 3))
    return Configuration(robot, robot.configuration(base=base, arm=rng.uniform(-2.5, 2.5, robot.n_arm)))


def test_self_collision_rows_are_the_nearest_pairs_distances_and_jacobians(robot, every_pair, rng):
    objective = SelfCollision(robot, min=0.02, band=0.05, pairs="all", count=3)
    assert objective.dim == 3 * POINTS and objective.links == candidate_pairs(robot, collision_geometry(robot)).links
    for _ in range(20):
        state = random_state(robot, rng)
        everything = every_pair.evaluate(state)
        nearest = np.argsort(everything.distance)[:3]
        rows = objective.rows(state)
        witness = rows.value[::POINTS]  # each pair's block: its witness, then its contact points (>= it)
        np.testing.assert_allclose(witness, everything.distance[nearest], rtol=0, atol=1e-12)
        np.testing.assert_allclose(rows.jacobian[::POINTS],
                                   every_pair.jacobian(state, everything.take(nearest), nearest), atol=1e-12)
        assert np.all(rows.value.reshape(3, POINTS) >= witness[:, None] - 1e-9)
        np.testing.assert_array_equal(rows.value, objective.value(state))
        np.testing.assert_array_equal(rows.jacobian, objective.jacobian(state))
        inside = np.clip((rows.value - 0.02) / 0.05, 0, 1)
        np.testing.assert_allclose(rows.activation, 0.5 * (1 + np.cos(np.pi * inside)), atol=1e-12)
        assert [d for *_, d in objective.nearest_pairs(state)] == list(witness)


def test_fewer_pairs_than_count_give_one_row_per_pair_and_listed_pairs_check_only_those(robot, every_pair, rng):
    assert SelfCollision(robot, pairs="all", count=50).dim == every_pair.count * POINTS == 8 * POINTS
    listed = SelfCollision(robot, pairs=[["jaw", "base_link"], ["link1", "link3"]], count=5)
    assert listed.dim == 2 * POINTS and listed.links == [("base_link", "jaw"), ("link1", "link3")]
    state = random_state(robot, rng)
    everything = every_pair.evaluate(state)
    np.testing.assert_allclose(listed.value(state)[::POINTS], np.sort(everything.distance[[2, 6]]), atol=1e-12)


@pytest.mark.parametrize(("options", "error", "words"), [
    (dict(pairs=[["jaw", "hull"]]), LinkNotFound, r"pair \[jaw, hull\] \(links with collision shapes\): "
                                                  r"unknown link 'hull'; valid names: base_link, arm_base"),
    (dict(pairs=[["link2", "jaw"]]), ObjectiveError, "'link2' and 'jaw' are adjacent"),
    (dict(pairs=[["link3", "jaw"]]), ObjectiveError, "'link3' and 'jaw' are same body"),
    (dict(pairs="jaw"), ObjectiveError, "pairs must be None, 'all' or a list"),
    (dict(count=0), ObjectiveError, "count must be a whole number >= 1"),
    (dict(band=0), ObjectiveError, "band must be a finite number > 0"),
])
def test_bad_self_collision_parameters_are_clear_errors(robot, options, error, words):
    with pytest.raises(error, match=words):
        SelfCollision(robot, **options)


def test_an_obstacle_keeps_a_frame_without_shapes_clear_as_a_point_with_its_closed_form(robot, rng):
    centre = np.array([0.5, -0.2, 0.3])
    sphere = Obstacle(robot, "sphere", radius=0.1, position=centre, frames=["j3"], count=1)
    plane = Obstacle(robot, "plane", point=[0, 0, -1], normal=[0, 0, 2], frames=["j3", "jaw"])
    assert sphere.links == [("obstacle(sphere)", "j3")] and plane.dim == 2 * POINTS
    frame = robot.frame_id("j3")
    for _ in range(10):
        state = random_state(robot, rng)
        point, jacobian = state.pose(frame).translation, state.jacobian(frame)[:3]
        gap = point - centre
        assert sphere.value(state)[0] == pytest.approx(np.linalg.norm(gap) - 0.1, abs=1e-9)
        np.testing.assert_allclose(sphere.jacobian(state)[0], gap / np.linalg.norm(gap) @ jacobian, atol=1e-9)
        jaw = state.pose(robot.frame_id("jaw"))
        jaw_low = jaw.translation[2] - 0.5 * np.array([0.06, 0.05, 0.03]) @ np.abs(jaw.rotation[2])
        np.testing.assert_allclose(plane.value(state)[::POINTS], np.sort([point[2] + 1, jaw_low + 1]), atol=1e-9)


def cube_stl(path: Path, side: float) -> Path:
    """An ASCII STL of a cube of ``side`` [m] centred at the origin (12 triangles)."""
    h = side / 2
    corners = np.array([[x, y, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6), (0, 2, 6),
             (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    text = "solid cube\n" + "".join("facet normal 0 0 0\nouter loop\n" + "".join(
        "vertex {:.9g} {:.9g} {:.9g}\n".format(*corners[i]) for i in face) + "endloop\nendfacet\n" for face in faces)
    path.write_text(text + "endsolid cube\n")
    return path


def test_a_mesh_obstacle_is_its_convex_hull_placed_in_the_world(robot, tmp_path, rng):
    mesh = cube_stl(tmp_path / "cube.stl", 0.4)
    placement = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([1.0, 0.5, -0.5]))
    obstacle = Obstacle(robot, "mesh", mesh=str(mesh), position=placement.translation, rpy=[0.1, 0.2, 0.3],
                        frames=["j3"], count=1)
    box = Obstacle(robot, "box", size=[0.4, 0.4, 0.4], position=placement.translation, rpy=[0.1, 0.2, 0.3],
                   frames=["j3"], count=1)
    for _ in range(10):
        state = random_state(robot, rng)
        local = placement.actInv(state.pose(robot.frame_id("j3")).translation)  # the point in the cube's frame
        outside = np.maximum(np.abs(local) - 0.2, 0.0)
        expected = np.linalg.norm(outside) if outside.any() else np.max(np.abs(local) - 0.2)
        assert obstacle.value(state)[0] == pytest.approx(expected, abs=1e-6)
        assert obstacle.value(state)[0] == pytest.approx(box.value(state)[0], abs=1e-6)


@pytest.mark.parametrize(("options", "error", "words"), [
    (dict(geometry="cone", radius=1.0), ObjectiveError, "unknown obstacle geometry 'cone'; valid: box, sphere"),
    (dict(geometry="box", size=[0.4, 0, 0.2]), ObjectiveError, r"size must be 3 sides > 0 \[m\]"),
    (dict(geometry="sphere", radius=0.0), ObjectiveError, "radius .* must be a finite number > 0"),
    (dict(geometry="cylinder", radius=0.1), ObjectiveError, "a cylinder obstacle takes radius, length, got radius"),
    (dict(geometry="box", size=[1, 1, 1], radius=0.1), ObjectiveError, "a box obstacle takes size, got radius, size"),
    (dict(geometry="plane", point=[0, 0, 0], normal=[0, 0, 0]), ObjectiveError, "normal must be a non-zero vector"),
    (dict(geometry="plane", point=[0, 0, 0], normal=[0, 0, 1], position=[1, 0, 0]), ObjectiveError,
     "placed by its point and normal"),
    (dict(geometry="mesh", mesh="/nonexistent/rock.stl"), ObjectiveError, "rock.stl' does not exist"),
    (dict(geometry="sphere", radius=0.1, frames=["jaww"]), FrameNotFound, "unknown frame 'jaww'; close names: jaw"),
    (dict(geometry="sphere", radius=0.1, frames="jaw"), ObjectiveError, "frames must be 'all' or a non-empty list"),
])
def test_bad_obstacles_are_clear_errors(robot, options, error, words):
    with pytest.raises(error, match=words):
        Obstacle(robot, **options)


def test_a_refused_or_flat_mesh_obstacle_is_a_clear_error(robot, tmp_path):
    (tmp_path / "rock.zae").write_bytes(b"PK\x03\x04")
    with pytest.raises(ObjectiveError, match=r"rock\.zae' is refused: format '\.zae' is not loaded"):
        Obstacle(robot, "mesh", mesh=tmp_path / "rock.zae")
    flat = cube_stl(tmp_path / "flat.stl", 0.4)
    flat.write_text(flat.read_text().replace(" -0.2\n", " 0\n").replace(" 0.2\n", " 0\n"))  # every z = 0
    with pytest.raises(ObjectiveError, match="flat.stl'.*the mesh is flat or empty"):
        Obstacle(robot, "mesh", mesh=flat)


def test_tables_build_both_objectives(robot):
    built = inequalities_from_table(robot, {"type": "self_collision", "min": 0.02, "pairs": "all", "count": 2})
    assert isinstance(built[0], SelfCollision) and built[0].dim == 2 * POINTS
    built = inequalities_from_table(robot, {"type": "obstacle", "geometry": "plane", "point": [0, 0, -2],
                                            "normal": [0, 0, 1], "min": 0.3, "frames": ["jaw", "link3"]})
    assert isinstance(built[0], Obstacle) and built[0].dim == 2 * POINTS and built[0].min == 0.3


def recorded_run(robot, solver, q0, steps=400, dt=0.02):
    state = Configuration(robot, q0)
    recorded = [state.q.copy()]
    for _ in range(steps):
        solver.step(state, dt)
        recorded.append(state.q.copy())
    return recorded


@pytest.mark.parametrize("method", ["set_based", "hqp"])
def test_the_jaw_folds_under_the_vehicle_without_passing_through_it_where_clik_does(robot, every_pair, method):
    q0 = robot.configuration(arm=[0.0, -1.0, 1.0])  # the jaw above the bow
    target = pin.SE3(np.eye(3), UNDER_THE_BOW)
    task = uvms.FrameTask(robot, frame="jaw", axes=("x", "y", "z"), target=target)
    straight = recorded_run(robot, CLIKSolver(robot, [task], gain=1.0, weights=ARM_FIRST), q0)
    assert min(every_pair.evaluate(Configuration(robot, q)).distance.min() for q in straight) < -0.04  # through
    levels = [SelfCollision(robot, min=0.02, band=0.05, pairs="all"), task]
    options = dict(gain=1.0, weights=ARM_FIRST) | (dict(dt=0.02) if method == "hqp" else {})
    solver = SetBasedSolver(robot, levels, **options) if method == "set_based" else HQPSolver(robot, levels, **options)
    run = recorded_run(robot, solver, q0)
    closest = min(every_pair.evaluate(Configuration(robot, q)).distance.min() for q in run)
    assert closest >= 0.02 - 1e-4  # min kept (the discrete step's overshoot below 0.1 mm)
    assert np.linalg.norm(robot.fk(run[-1], "jaw").translation - UNDER_THE_BOW) < 1e-3  # and the jaw arrives


def test_a_start_in_collision_moves_out_at_the_reference_rate(robot, every_pair):
    """Damped as the shipped collision scenarios are: undamped, the box's near-duplicate corner rows in contact
    ask for joint rates of 500-4,500 rad/s for a few steps on the way out (measured), and whether the jaw then
    lands outside or 17 cm inside the vehicle turned on the last bits of coal's distances."""
    q0 = robot.configuration(arm=[np.pi, -0.5, 1.8])  # the arm turned back, the jaw 3 cm deep in the vehicle's top
    start = every_pair.evaluate(Configuration(robot, q0)).distance.min()
    assert start < 0
    hold = uvms.FrameTask(robot, frame="jaw", axes=("x", "y", "z"), target=robot.fk(q0, "jaw"))
    solver = SetBasedSolver(robot, [SelfCollision(robot, min=0.02, band=0.05, pairs="all", gain=1.0), hold],
                            weights=ARM_FIRST, damping=0.01)
    run = recorded_run(robot, solver, q0, steps=300, dt=0.01)
    closest = np.array([every_pair.evaluate(Configuration(robot, q)).distance.min() for q in run])
    assert np.all(np.diff(closest[closest < 0.02]) > 0)  # out, step after step, while inside min
    rates = np.diff(run, axis=0)[:, -3:] / 0.01  # the arm's joint rates (revolute: q's last entries)
    assert np.abs(rates).max() < 2.0  # no burst on the way out [rad/s]
    assert closest[-1] >= 0.02 - 1e-4
    # the rate of a row outside its set: gain (min + band - d) at the start, 1 s^-1 here
    rate = (closest[1] - closest[0]) / 0.01
    assert rate == pytest.approx(0.02 + 0.05 - start, rel=0.1)


def test_a_face_parallel_to_an_obstacle_gives_its_corners_as_rows():
    """The jaws' box of the Alpha 5 turned so that a face lies parallel to a plane: its witness is one point of the
    face, and the rows hold the features that tie with it (points on the face's edges and corners, each at the
    face's distance), so no turn of the face can take one row out while another part of the face goes in (issue
    48: the pipe without weights, 14 mm inside). Each row's Jacobian is the rate of its point along the normal."""
    robot = uvms.load(ROOT / "models" / "bluerov2_alpha5" / "uvms.urdf.xacro")
    q = robot.configuration(base=pin.SE3(np.eye(3), np.array([0.0, 0.0, -5.0])), arm=[3.0, 1.8, 1.8, 1.0, 0.0])
    state = Configuration(robot, q)
    jaw = robot.model.getFrameId("alpha_jaw_link")
    pose = state.pose(jaw)
    # a plane facing the jaw box's local -x face, 3 cm beyond it: the face parallel to the plane
    normal = -pose.rotation[:, 0]
    plane = Obstacle(robot, "plane", point=(pose.translation + 0.1 * normal).tolist(), normal=(-normal).tolist(),
                     frames=["alpha_jaw_link"], min=0.0, band=1.0, count=1)
    chosen, found = plane.nearest(state)
    assert found.distance.size == POINTS
    np.testing.assert_allclose(found.distance, found.distance[0], atol=1e-9)  # every feature of the face ties
    local = np.array([pose.actInv(point) for point in found.point2])  # on the face, in the box's frame
    assert np.ptp(local[:, 1]) > 0.02 and np.ptp(local[:, 2]) > 0.02  # spread over the face, not one point
    rows = plane.rows(state)
    step = 1e-6 * np.random.default_rng(3).standard_normal(robot.nv)
    moved = Configuration(robot, pin.integrate(robot.model, q, step))
    for point, row in zip(found.point2, rows.jacobian):  # each row: its body point's rate along the plane's normal
        carried = moved.pose(jaw).act(pose.actInv(point))
        assert abs((-normal) @ (carried - point) - row @ step) < 1e-10
