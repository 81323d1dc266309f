"""The vehicle's solids read from a ROS-style model: a hull on a child of a massless root, a mesh as its convex hull."""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.errors import WorkspaceInputError
from uvms.workspace import HullShape, hull_shapes, monte_carlo, outside_hull

BOX = np.array([1.2, 0.6, 0.4])  # edges of the mesh hull [m]
INERTIA = 'ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"'


def cube_stl(edges: np.ndarray) -> str:
    """An ASCII STL of a box centred at the origin with the given edges [m] (12 triangles)."""
    corner = lambda signs: 0.5 * edges * np.array(signs)  # noqa: E731
    faces = []
    for axis in range(3):
        for side in (-1, 1):
            others = [a for a in range(3) if a != axis]
            square = []
            for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                signs = [0, 0, 0]
                signs[axis], signs[others[0]], signs[others[1]] = side, s, t
                square.append(corner(signs))
            faces += [(square[0], square[1], square[2]), (square[0], square[2], square[3])]
    facets = "".join("facet normal 0 0 0\n outer loop\n" + "".join(f"  vertex {p[0]} {p[1]} {p[2]}\n" for p in tri)
                     + " endloop\nendfacet\n" for tri in faces)
    return f"solid box\n{facets}endsolid box\n"


def ros_vehicle(folder, mesh_xyz=(0.1, 0.0, 0.05)) -> str:
    """A vehicle as ROS packages write it: a massless ``base_footprint`` root, the hull (a mesh, scaled by 2) on
    ``base_link`` below a fixed joint, a uuv_simulator plugin naming ``base_link`` again, one arm joint."""
    (folder / "meshes").mkdir()
    (folder / "meshes" / "hull.stl").write_text(cube_stl(BOX / 2))
    xyz = " ".join(map(str, mesh_xyz))
    path = folder / "vehicle.urdf"
    path.write_text(f"""<robot name="rov">
  <link name="world"/>
  <link name="base_footprint"/>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="base_footprint"/></joint>
  <link name="base_link">
    <inertial><mass value="100"/><inertia {INERTIA}/></inertial>
    <visual><origin xyz="{xyz}"/><geometry><mesh filename="meshes/hull.stl" scale="2 2 2"/></geometry></visual>
  </link>
  <joint name="footprint_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/></joint>
  <link name="arm_link"><inertial><mass value="1"/><inertia {INERTIA}/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base_link"/><child link="arm_link"/>
    <origin xyz="0 0 -0.3"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="ee"/>
  <joint name="ee_joint" type="fixed"><parent link="arm_link"/><child link="ee"/><origin xyz="0.5 0 0"/></joint>
  <gazebo><plugin name="hydro" filename="libuuv_underwater_object_ros_plugin.so">
    <link name="base_link"><volume>0.1</volume></link></plugin></gazebo>
</robot>
""")
    return path


def test_a_convex_hull_holds_the_points_of_the_solid_it_spans():
    rng = np.random.default_rng(3)
    corners = np.array(list(itertools.product(*[(-h, h) for h in 0.5 * BOX])))
    inner = rng.uniform(-0.5, 0.5, (50, 3)) * BOX  # points inside do not change the hull
    rotation = pin.rpy.rpyToMatrix(0.3, -0.2, 1.0)
    convex = HullShape("hull", "convex", rotation, np.array([1.0, 2.0, 3.0]), vertices=np.vstack([corners, inner]))
    box = HullShape("hull", "box", rotation, np.array([1.0, 2.0, 3.0]), BOX)
    probe = np.array([1.0, 2.0, 3.0]) + rng.uniform(-0.7, 0.7, (20_000, 3))
    assert np.array_equal(convex.contains(probe), box.contains(probe))
    assert 0.05 < convex.contains(probe).mean() < 0.2  # the probe cuts the solid, not all in or all out
    assert convex.volume == pytest.approx(np.prod(BOX), rel=1e-12) and np.allclose(convex.size, BOX)
    assert len(convex.vertices) == 8  # the hull's own points
    with pytest.raises(WorkspaceInputError, match="span no volume"):
        HullShape("hull", "convex", np.eye(3), np.zeros(3), vertices=corners * [1, 1, 0])


def test_the_hull_of_a_ros_vehicle_is_its_mesh_on_the_child_of_a_massless_root(tmp_path):
    robot = uvms.load(ros_vehicle(tmp_path), ee="ee")
    (shape,) = hull_shapes(robot)  # base_footprint holds nothing; base_link's mesh, not the plugin's <link>
    assert shape.link == "base_link" and shape.kind == "convex"
    assert np.allclose(shape.size, BOX, rtol=1e-6) and shape.volume == pytest.approx(np.prod(BOX), rel=1e-6)
    centre = np.array([0.1, 0.0, 0.05])
    assert outside_hull(np.array([centre, centre + [0.59, 0.29, 0.19], centre + [0.61, 0, 0]]), shape).tolist() == [
        False, False, True]
    # the arm's tip sweeps a 0.5 m circle about the shoulder 0.3 m below the hull centre: the part of it inside goes
    result = monte_carlo(robot, ["ee"], 4_000, remove_hull=True, progress=False)
    points = result.positions["ee"]
    expected = np.all(np.abs(points - centre) <= 0.5 * BOX, axis=1)
    assert expected.any() and np.array_equal(~result.outside_hull["ee"], expected)


def test_a_missing_mesh_is_skipped_with_a_warning(tmp_path):
    path = ros_vehicle(tmp_path)
    (tmp_path / "meshes" / "hull.stl").unlink()
    with pytest.warns(UserWarning, match="hull.stl"):
        robot = uvms.load(path, ee="ee")
    with pytest.warns(UserWarning, match="not found"), pytest.raises(WorkspaceInputError, match="no box"):
        hull_shapes(robot)
