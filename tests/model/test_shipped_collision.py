"""The shipped models' <collision> shapes (models/bluerov2_alpha5/uvms.urdf.xacro and uvms.srdf), read with Pinocchio's
GeometryModel and measured with coal directly (no uvms distance code).

The BlueROV2 + Alpha 5 carries primitives only; each size follows its xacro arg; the thruster guards sit on the
thrusters of thrusters.yaml; the SRDF disables only pairs that touch by design (or can never meet); the scenarios
start clear of every checked pair, and folding the jaws up into the frame is a collision whose depth equals the
jaw box's corner above the frame's bottom face (an independent computation from the kinematics).
"""

from __future__ import annotations

import itertools
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
import tomllib

import uvms
from uvms.dynamics.thrusters.thrusters import thrusters_of

from conftest import ROOT, SCENARIOS, shipped

MODEL = "bluerov2_alpha5"
SRDF = ROOT / "models" / MODEL / "uvms.srdf"
# <collision> shapes per link: side panels, top, bottom, two enclosures, eight thruster guards; the Alpha 5's
# modules (the shoulder carries the E and D housings, the elbow the elbow and C housings); the jaws' envelope
SHAPES = {"base_link": ["Box"] * 4 + ["Cylinder"] * 10, "alpha_m3_inline_link": ["Cylinder"],
          "alpha_m2_1_1_link": ["Cylinder"] * 2, "alpha_m2_joint_link": ["Cylinder"],
          "alpha_m2_1_2_link": ["Cylinder"] * 2, "alpha_m1_link": ["Cylinder"], "alpha_jaw_link": ["Box"]}
STOWED_IN_FRAME = [np.pi, 3.2, 0.6, 0.0, 0.0]  # E, D, C, B [rad], A [m]: the jaws folded up into the frame's bottom


def collision_model(robot: uvms.Robot, srdf: bool = True) -> pin.GeometryModel:
    """The robot's collision shapes with every pair between different joints, minus the SRDF's pairs."""
    geometry = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.COLLISION)
    geometry.addAllCollisionPairs()
    if srdf:
        pin.removeCollisionPairsFromXML(robot.model, geometry, SRDF.read_text())
    return geometry


def distances(robot: uvms.Robot, geometry: pin.GeometryModel, q: np.ndarray) -> dict[tuple[str, str], float]:
    """Signed distance [m] of every active pair at q, keyed by the two geometry names (negative: overlap)."""
    data = pin.GeometryData(geometry)
    pin.computeDistances(robot.model, robot.model.createData(), geometry, data, q)
    names = [item.name for item in geometry.geometryObjects]
    return {(names[pair.first], names[pair.second]): data.distanceResults[k].min_distance
            for k, pair in enumerate(geometry.collisionPairs)}


def shapes_of(geometry: pin.GeometryModel, link: str) -> list[pin.GeometryObject]:
    return [item for item in geometry.geometryObjects if item.name.rsplit("_", 1)[0] == link]


def scenario_starts() -> list[tuple[str, list[float], list[float]]]:
    starts = []
    for path in sorted(SCENARIOS.glob(f"{MODEL}_*.toml")):
        initial = tomllib.loads(path.read_text())["initial"]
        starts.append((path.stem, initial["base"], initial["arm"]))
    return starts


def test_shapes_are_primitives_on_their_links():
    geometry = collision_model(shipped(MODEL))
    found = {link: [type(item.geometry).__name__ for item in shapes_of(geometry, link)] for link in SHAPES}
    assert found == SHAPES and geometry.ngeoms == sum(len(kinds) for kinds in SHAPES.values())


def test_sizes_follow_the_xacro_args():
    args = {"alpha_module_radius": 0.025, "alpha_upper_arm_length": 0.15, "alpha_jaw_size_y": 0.05,
            "thruster_guard_diameter": 0.11, "thruster_guard_length": 0.12, "frame_width": 0.36,
            "frame_panel_thickness": 0.015, "electronics_tube_length": 0.3, "battery_tube_diameter": 0.1}
    robot = uvms.load(MODEL, args=args)
    geometry = collision_model(robot)
    base = shapes_of(geometry, "base_link")
    panel = base[0]
    assert np.allclose(panel.geometry.halfSide * 2, [0.457, 0.015, 0.254], atol=1e-12)
    assert panel.placement.translation[1] == pytest.approx((0.36 - 0.015) / 2, abs=1e-12)
    assert np.allclose(base[2].geometry.halfSide[1] * 2, 0.36 - 2 * 0.015, atol=1e-12)  # top, between the panels
    assert base[4].geometry.halfLength * 2 == pytest.approx(0.3, abs=1e-12)  # electronics enclosure
    assert base[5].geometry.radius == pytest.approx(0.05, abs=1e-12)  # battery enclosure
    for guard in base[6:]:
        assert (guard.geometry.radius, guard.geometry.halfLength) == pytest.approx((0.055, 0.06), abs=1e-12)
    (upper_arm,) = shapes_of(geometry, "alpha_m2_joint_link")
    assert (upper_arm.geometry.radius, upper_arm.geometry.halfLength) == pytest.approx((0.025, 0.075), abs=1e-12)
    (jaws,) = shapes_of(geometry, "alpha_jaw_link")
    assert np.allclose(jaws.geometry.halfSide * 2, [0.012, 0.05, 0.09], atol=1e-12)
    # at Reach's zero the upper arm crosses the base tube, the two axes meeting: overlap 2 r (closed form)
    q = robot.configuration(arm=np.zeros(robot.n_arm))
    assert distances(robot, geometry, q)[("alpha_m3_inline_link_0", "alpha_m2_joint_link_0")] == pytest.approx(
        -2 * 0.025, abs=1e-9)


def test_thruster_guards_sit_on_the_thrusters_of_thrusters_yaml():
    robot = shipped(MODEL)
    guards = shapes_of(collision_model(robot), "base_link")[6:]
    thrusters = thrusters_of(robot)
    assert len(guards) == len(thrusters) == 8
    for guard, thruster in zip(guards, thrusters.items):
        assert thruster.parent == "base_link"
        assert np.allclose(guard.placement.translation, thruster.position, atol=1e-12), thruster.name
        axis = guard.placement.rotation[:, 2]  # a cylinder's axis is its local z
        assert abs(axis @ thruster.direction) == pytest.approx(1.0, abs=1e-12), thruster.name
        assert (guard.geometry.radius, guard.geometry.halfLength) == pytest.approx((0.05, 0.0565), abs=1e-12)


def test_srdf_pairs_are_links_with_shapes_and_remove_only_their_pairs():
    robot = shipped(MODEL)
    disabled = [(item.get("link1"), item.get("link2"), item.get("reason"))
                for item in ET.parse(SRDF).getroot().iter("disable_collisions")]
    assert {link for pair in disabled for link in pair[:2]} <= set(SHAPES)
    assert {reason for *_, reason in disabled} == {"Adjacent", "Always", "Never"}
    everything, checked = collision_model(robot, srdf=False), collision_model(robot)
    names = [item.name for item in everything.geometryObjects]

    def links(pair: pin.CollisionPair) -> frozenset[str]:
        return frozenset(names[index].rsplit("_", 1)[0] for index in (pair.first, pair.second))

    off = {frozenset(pair[:2]) for pair in disabled}
    expected = [pair for pair in everything.collisionPairs if links(pair) not in off]
    assert len(checked.collisionPairs) == len(expected) == 85


def test_disabled_pairs_touch_by_design_or_never_meet(rng):
    """Always: overlapping at every configuration; Never: >= 0.10 m apart; Adjacent: touching (<= 0) somewhere."""
    robot = shipped(MODEL)
    everything = collision_model(robot, srdf=False)
    lower, upper = robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:]
    samples = [distances(robot, everything, robot.configuration(arm=rng.uniform(lower, upper))) for _ in range(60)]

    def closest(link1: str, link2: str) -> np.ndarray:
        keys = [key for key in samples[0] if {key[0].rsplit("_", 1)[0], key[1].rsplit("_", 1)[0]} == {link1, link2}]
        return np.array([min(sample[key] for key in keys) for sample in samples])

    assert np.all(closest("base_link", "alpha_m2_1_1_link") < -0.02)
    assert np.all(closest("alpha_m2_1_2_link", "alpha_jaw_link") > 0.10)
    for link1, link2 in [("alpha_m2_1_1_link", "alpha_m2_joint_link"), ("alpha_m2_joint_link", "alpha_m2_1_2_link"),
                         ("alpha_m2_1_2_link", "alpha_m1_link")]:
        assert closest(link1, link2).min() <= 1e-9, (link1, link2)


@pytest.mark.parametrize(("scenario", "base", "arm"), scenario_starts())
def test_scenarios_start_clear_of_every_checked_pair(scenario, base, arm):
    robot = shipped(MODEL)
    values = distances(robot, collision_model(robot), robot.configuration(base=np.array(base), arm=np.array(arm)))
    pair = min(values, key=values.get)
    assert values[pair] > 0.02, (scenario, pair, values[pair])


def test_arm_stretched_ahead_is_clear():
    robot = shipped(MODEL)
    values = distances(robot, collision_model(robot),
                       robot.configuration(arm=np.array([np.pi, np.pi / 2, np.pi, 0, 0])))
    assert min(values.values()) > 0.02


def test_jaws_folded_into_the_frame_collide_by_their_corner_depth():
    robot = shipped(MODEL)
    q = robot.configuration(arm=np.array(STOWED_IN_FRAME))
    values = distances(robot, collision_model(robot), q)
    # independent: the jaw box's corners from the kinematics and the xacro's jaw args; the frame's bottom face is
    # at -H/2 of the 0.254 m envelope (the base at the origin), and the corner lies within its footprint
    jaw = robot.fk(q, "alpha_jaw_link")
    half, centre = np.array([0.012, 0.045, 0.09]) / 2, np.array([0.0, 0.0, 0.0069 + 0.045])
    corners = np.array([jaw.act(centre + half * np.array(sign)) for sign in itertools.product((-1, 1), repeat=3)])
    top = corners[np.argmax(corners[:, 2])]
    assert abs(top[0]) < 0.457 / 2 and abs(top[1]) < 0.338 / 2 - 0.0127
    depth = top[2] - (-0.254 / 2)
    assert values[("base_link_3", "alpha_jaw_link_0")] == pytest.approx(-depth, abs=1e-9)
    assert -0.02 < -depth < -0.01
    links = {key: value for key, value in values.items() if "alpha_jaw_link" not in key[1]}
    assert min(links.values()) > 0.0  # only the jaws are in the frame (and in the arm's base tube)
