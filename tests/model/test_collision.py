"""Collision geometry of a model (uvms.model.collision): shapes attached to the right joints through fixed joints,
meshes as convex hulls, capsules, the pairs checked (adjacent, same body, SRDF, colliding at a reference), and the
errors of bad geometry and bad SRDFs."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.errors import CollidingPairWarning, LinkNotFound, ModelCheckError
from uvms.model.collision import (
    ADJACENT,
    COLLIDING,
    SAME_BODY,
    SRDF,
    candidate_pairs,
    collision_geometry,
    collision_pairs,
    read_srdf,
)
from uvms.robot.configuration import Configuration

FIXTURES = Path(__file__).parents[1] / "fixtures" / "collision"
BOX_ARM = FIXTURES / "box_arm.urdf"
#: box_arm's checked pairs: the vehicle (base_link + arm_base on joint 1), link1 (j1), link2 (j2), link3 + jaw (j3).
BOX_ARM_PAIRS = [("base_link", "link2"), ("base_link", "link3"), ("base_link", "jaw"), ("arm_base", "link2"),
                 ("arm_base", "link3"), ("arm_base", "jaw"), ("link1", "link3"), ("link1", "jaw")]


def load(path=BOX_ARM, **options):
    with pytest.warns(uvms.errors.BaseGuessWarning):
        return uvms.load(path, **options)


def test_shapes_on_links_behind_fixed_joints_ride_on_the_joint_that_carries_them(rng):
    robot = load()
    geometry = collision_geometry(robot)
    joints = {robot.model.frames[item.parentFrame].name: robot.model.names[item.parentJoint]
              for item in geometry.geometryObjects}
    assert joints == {"base_link": "base_joint", "arm_base": "base_joint", "link1": "j1", "link2": "j2",
                      "link3": "j3", "jaw": "j3"}
    state = Configuration(robot, robot.random_configuration(rng))
    for item in geometry.geometryObjects:  # each shape where the URDF puts it: its link's pose times its origin
        link = state.pose(robot.frame_id(robot.model.frames[item.parentFrame].name))
        placed = state.joint_pose(item.parentJoint) * item.placement
        origin = {"link1": [0, 0, 0.075], "link2": [0.15, 0, 0], "link3": [0.1, 0, 0]}.get(
            robot.model.frames[item.parentFrame].name, [0, 0, 0])
        np.testing.assert_allclose(placed.translation, link.act(np.array(origin, dtype=float)), atol=1e-12)
    assert [type(item.geometry).__name__ for item in geometry.geometryObjects] == [
        "Box", "Sphere", "Cylinder", "Cylinder", "Cylinder", "Box"]


def test_pairs_leave_out_shapes_on_one_body_and_on_adjacent_bodies():
    robot = load()
    pairs = candidate_pairs(robot, collision_geometry(robot))
    assert pairs.links == BOX_ARM_PAIRS
    assert pairs.disabled == {("base_link", "arm_base"): SAME_BODY, ("base_link", "link1"): ADJACENT,
                              ("arm_base", "link1"): ADJACENT, ("link1", "link2"): ADJACENT,
                              ("link2", "link3"): ADJACENT, ("link2", "jaw"): ADJACENT, ("link3", "jaw"): SAME_BODY}


@pytest.mark.parametrize("where", [".", "../srdf"])
def test_an_srdf_beside_the_model_disables_its_pairs(tmp_path, where):
    model = tmp_path / "urdf" / "box_arm.urdf"
    model.parent.mkdir()
    shutil.copy(BOX_ARM, model)
    (model.parent / where).mkdir(exist_ok=True)
    (model.parent / where / "box_arm.srdf").write_text(
        '<robot name="box_arm"><disable_collisions link1="jaw" link2="base_link" reason="Never"/>'
        '<disable_collisions link1="link1" link2="link3"/></robot>')
    robot = load(model)
    pairs = collision_pairs(robot, collision_geometry(robot))
    assert pairs.links == [p for p in BOX_ARM_PAIRS if p not in (("base_link", "jaw"), ("link1", "link3"))]
    assert pairs.disabled[("base_link", "jaw")] == SRDF and pairs.disabled[("link1", "link3")] == SRDF


def test_without_an_srdf_pairs_colliding_at_the_reference_configuration_are_disabled_with_a_warning():
    robot = load()
    geometry = collision_geometry(robot)
    with warnings.catch_warnings():
        warnings.simplefilter("error", CollidingPairWarning)
        assert collision_pairs(robot, geometry).links == BOX_ARM_PAIRS  # the neutral configuration is clear
    folded = robot.configuration(arm=[0.0, 2.0, 0.0])  # link2 swung down through the vehicle's bow
    with pytest.warns(CollidingPairWarning, match="2 pair.*not checked: arm_base-link2, base_link-link2") as caught:
        pairs = collision_pairs(robot, geometry, q=folded)
    assert pairs.links == [p for p in BOX_ARM_PAIRS if p not in (("base_link", "link2"), ("arm_base", "link2"))]
    assert pairs.disabled[("base_link", "link2")] == pairs.disabled[("arm_base", "link2")] == COLLIDING
    assert len(caught) == 1


def test_the_ur5s_meshes_become_convex_hulls_and_its_srdf_is_read():
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="fixed")
    geometry = collision_geometry(robot)
    hulls = [item for item in geometry.geometryObjects if isinstance(item.geometry, coal.ConvexBase)]
    assert len(hulls) == 7 and all(item.geometry.computeVolume() > 1e-4 for item in hulls)
    srdf = Path(uvms.model.example_robot_urdf("ur5")).parents[1] / "srdf" / "ur5.srdf"
    pairs = collision_pairs(robot, geometry, srdf=srdf)
    assert ("base_link", "wrist_1_link") in pairs.links
    assert all(frozenset(p) not in {frozenset(e) for e in read_srdf(srdf, robot.frame_names)} for p in pairs.links)
    assert pairs.disabled[("wrist_1_link", "wrist_3_link")] == SRDF


def test_a_capsule_which_pinocchios_parser_drops_is_built_from_the_urdf():
    capsule = ('<link name="tip"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" '
               'ixz="0" iyz="0"/></inertial><collision><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>'
               '<geometry><capsule radius="0.02" length="0.3"/></geometry></collision></link>'
               '<joint name="tip_mount" type="fixed"><parent link="link3"/><child link="tip"/>'
               '<origin xyz="0.2 0 0"/></joint></robot>')
    text = BOX_ARM.read_text().replace("</robot>", capsule)
    with pytest.warns(uvms.errors.ParserWarning):  # Pinocchio's URDF parser says it cannot read the capsule
        robot = load(text)
    item = next(i for i in collision_geometry(robot).geometryObjects if i.name == "tip_0")
    assert isinstance(item.geometry, coal.Capsule) and item.geometry.radius == 0.02
    assert item.geometry.halfLength == pytest.approx(0.15) and robot.model.names[item.parentJoint] == "j3"
    np.testing.assert_allclose(item.placement.translation, [0.3, 0, 0], atol=1e-12)
    np.testing.assert_allclose(item.placement.rotation[:, 2], [1, 0, 0], atol=1e-12)  # its axis along link3


MESHED = ('<robot name="meshed"><link name="hull"><inertial><mass value="5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" '
          'ixz="0" iyz="0"/></inertial><collision><geometry><mesh filename="{mesh}"/></geometry></collision></link>'
          '</robot>')


def test_a_missing_or_refused_mesh_and_a_zero_size_shape_are_clear_errors(tmp_path):
    with pytest.warns(uvms.errors.MissingMeshWarning):
        robot = uvms.load(MESHED.format(mesh=str(tmp_path / "gone.stl")), base="floating")
    with pytest.raises(ModelCheckError, match=r"link 'hull': the collision mesh '.*gone\.stl' cannot be found"):
        collision_geometry(robot)
    (tmp_path / "hull.zae").write_bytes(b"PK\x03\x04")
    robot = uvms.load(MESHED.format(mesh=str(tmp_path / "hull.zae")), base="floating")
    with pytest.raises(ModelCheckError, match=r"hull\.zae' is refused: format '\.zae' is not loaded"):
        collision_geometry(robot)
    with pytest.raises(ModelCheckError, match="geometry size must be > 0"):
        uvms.load(BOX_ARM.read_text().replace('<sphere radius="0.04"/>', '<sphere radius="0"/>'))


def test_a_missing_visual_mesh_does_not_stop_the_collision_geometry(tmp_path):
    visual = '<visual><geometry><mesh filename="{}"/></geometry></visual><collision>'.format(tmp_path / "gone.dae")
    with pytest.warns(uvms.errors.MissingMeshWarning):
        robot = load(BOX_ARM.read_text().replace("<collision>", visual, 1))
    assert collision_geometry(robot).ngeoms == 6


def test_a_flat_mesh_has_no_hull_and_says_so(tmp_path):
    flat = tmp_path / "flat.stl"
    flat.write_text("solid flat\n" + "".join(
        f"facet normal 0 0 1\nouter loop\nvertex {a}\nvertex {b}\nvertex {c}\nendloop\nendfacet\n"
        for a, b, c in [("0 0 0", "1 0 0", "0 1 0"), ("1 0 0", "1 1 0", "0 1 0")]) + "endsolid flat\n")
    robot = uvms.load(MESHED.format(mesh=str(flat)), base="floating")
    with pytest.raises(ModelCheckError, match="flat.stl.*(vertices|no convex hull|no volume)"):
        collision_geometry(robot)


@pytest.mark.parametrize(("text", "error", "words"), [
    ('<robot><disable_collisions link1="jaw" link2="base_lnk"/></robot>', LinkNotFound,
     r"unknown link 'base_lnk'; close names: base_link"),
    ('<robot><disable_collisions link1="jaw"/></robot>', ModelCheckError, "needs link1 and link2"),
    ('<!DOCTYPE r [<!ENTITY a "aaaa">]><robot>&a;</robot>', ModelCheckError, "declares an XML entity"),
    ('<robot><disable_collisions', ModelCheckError, "not well-formed XML"),
])
def test_a_bad_srdf_is_a_clear_error(tmp_path, text, error, words):
    robot = load()
    path = tmp_path / "bad.srdf"
    path.write_text(text)
    with pytest.raises(error, match=words):
        collision_pairs(robot, collision_geometry(robot), srdf=path)


def test_an_srdf_larger_than_its_cap_is_refused_unread(tmp_path):
    path = tmp_path / "huge.srdf"
    with open(path, "wb") as handle:
        handle.truncate(2 << 20)
    with pytest.raises(ModelCheckError, match="at most 1 MiB"):
        read_srdf(path, ["a"])


def test_a_robot_built_from_a_pinocchio_model_alone_has_no_collision_geometry():
    robot = uvms.Robot(pin.buildSampleModelManipulator())
    with pytest.raises(ModelCheckError, match="has no URDF"):
        collision_geometry(robot)
