"""ROS description-package idioms of issue 32 that load as they are.

Both xacro namespaces (``http://www.ros.org/wiki/xacro``, ``http://ros.org/wiki/xacro`` and their https forms)
declare args that ``args=`` may set; uuv_simulator's point-mass thruster links (a mass, an all-zero inertia)
load with a warning unless they make the mass matrix singular.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.errors import PointMassWarning
from uvms.model import read_model_text
from uvms.model.includes import XACRO_NAMESPACES, walk_xacro

INERTIA = 'ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"'


def arm_xacro(namespace: str) -> str:
    """A floating hull with one revolute joint whose tip frame ``ee`` sits ``length`` [m] along x (a xacro arg)."""
    return f"""<?xml version="1.0"?>
<robot name="ns_test" xmlns:xacro="{namespace}">
  <xacro:arg name="length" default="0.5"/>
  <xacro:property name="length" value="$(arg length)"/>
  <link name="world"/>
  <link name="hull"><inertial><mass value="10"/><inertia {INERTIA.format(i=1)}/></inertial></link>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull"/></joint>
  <link name="link1"><inertial><mass value="1"/><inertia {INERTIA.format(i=0.01)}/></inertial></link>
  <joint name="j1" type="revolute"><parent link="hull"/><child link="link1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <link name="ee"/>
  <joint name="ee_joint" type="fixed"><parent link="link1"/><child link="ee"/>
    <origin xyz="${{length}} 0 0"/></joint>
</robot>
"""


@pytest.mark.parametrize("namespace", XACRO_NAMESPACES)
def test_each_xacro_namespace_declares_args_that_set_a_link_length(tmp_path, namespace):
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(arm_xacro(namespace))
    assert walk_xacro(path).args == {"length": "0.5"}
    robot = uvms.load(path, args={"length": 0.8}, trusted=True, ee="ee")
    q = pin.neutral(robot.model)
    assert robot.fk(q, "ee").translation == pytest.approx([0.8, 0.0, 0.0], abs=1e-12)
    assert uvms.load(path, trusted=True, ee="ee").fk(q, "ee").translation[0] == pytest.approx(0.5, abs=1e-12)
    with pytest.raises(uvms.errors.XacroError, match=r"unknown xacro arg\(s\) lenght; this model declares: length$"):
        uvms.load(path, args={"lenght": 0.8}, trusted=True)


def test_a_namespace_of_its_own_bound_to_the_xacro_prefix_is_read_as_xacro_reads_it(tmp_path):
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(arm_xacro("http://example.org/my-xacro"))
    assert walk_xacro(path).args == {"length": "0.5"}


def test_the_other_namespace_through_an_include_in_the_sandbox(tmp_path):
    (tmp_path / "arm.xacro").write_text(arm_xacro("http://ros.org/wiki/xacro"))
    top = tmp_path / "top.urdf.xacro"
    top.write_text('<robot name="top" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                   '<xacro:include filename="arm.xacro"/></robot>')
    assert walk_xacro(top).args == {"length": "0.5"}
    robot = uvms.load(top, args={"length": 1.25}, ee="ee")  # untrusted: expanded in the sandbox
    assert robot.fk(pin.neutral(robot.model), "ee").translation[0] == pytest.approx(1.25, abs=1e-12)
    with pytest.raises(uvms.errors.XacroError, match="this model declares: length"):
        uvms.load(top, args={"width": 1})


# ------------------------------------------------------------------ point masses (uuv_simulator thruster links)
def with_link(urdf: str, joint_type: str, name: str = "thruster_0", mass: str = "0.001", inertia: float = 0) -> str:
    """hoang2011's URDF with one more link on ``base_link``, of ``mass`` and inertia ``inertia`` I."""
    link = (f'<link name="{name}"><inertial><mass value="{mass}"/><inertia {INERTIA.format(i=inertia)}/>'
            f'</inertial></link><joint name="{name}_joint" type="{joint_type}"><parent link="base_link"/>'
            f'<child link="{name}"/><origin xyz="-0.4 0.1 0"/><axis xyz="1 0 0"/></joint>')
    return urdf.replace("</robot>", link + "</robot>")


@pytest.fixture(scope="module")
def hoang() -> str:
    return read_model_text("hoang2011")[0]


def test_a_tiny_point_mass_thruster_link_loads_with_one_warning_naming_it(hoang):
    plain = uvms.load("hoang2011")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = uvms.load(with_link(hoang, "fixed"))
    notes = [w for w in caught if issubclass(w.category, PointMassWarning)]
    assert len(notes) == 1 and "thruster_0" in str(notes[0].message) and "point mass" in str(notes[0].message)
    q = robot.configuration(base=[0.3, -0.2, 0.4], arm=[0.1, 0.2, 0.3])
    assert robot.n_arm == plain.n_arm == 3
    assert np.allclose(robot.fk(q).homogeneous, plain.fk(q).homogeneous)
    mass_matrix = pin.crba(robot.model, robot.model.createData(), q)
    plain_mass_matrix = pin.crba(plain.model, plain.model.createData(), q)
    assert np.all(np.isfinite(mass_matrix))
    assert np.min(np.linalg.eigvalsh(np.triu(mass_matrix) + np.triu(mass_matrix, 1).T)) > 0
    assert mass_matrix[0, 0] - plain_mass_matrix[0, 0] == pytest.approx(0.001, abs=1e-12)  # the thruster's 1 g


def test_a_point_mass_on_its_own_joint_makes_the_mass_matrix_singular_and_is_refused(hoang):
    with pytest.warns(PointMassWarning), pytest.raises(
            uvms.errors.ModelCheckError, match=r"mass matrix is singular.*spinner.*positive definite <inertia>"):
        uvms.load(with_link(hoang, "continuous", name="spinner"))  # spinning about its own axis: no inertia at all
    with pytest.warns(PointMassWarning):  # named like a propeller: frozen (uvms.model.propellers), a point mass
        robot = uvms.load(with_link(hoang, "continuous"))
    assert robot.joint_classes["thruster_0_joint"].kind == "propeller" and robot.model.nv == 6


def test_a_propeller_with_an_inertia_is_no_point_mass(hoang):
    with warnings.catch_warnings():
        warnings.simplefilter("error", PointMassWarning)
        robot = uvms.load(with_link(hoang, "continuous", name="spinner", inertia=1e-6))
    assert robot.model.nv == 7


@pytest.mark.parametrize(("mass", "inertia", "message"), [
    ("0.001", -1e-3, "not positive definite"),
    ("-1", 0, "a mass must be positive"),
])
def test_negative_inertia_and_mass_are_still_refused(hoang, mass, inertia, message):
    with pytest.raises(uvms.errors.ModelCheckError, match=message):
        uvms.load(with_link(hoang, "fixed", mass=mass, inertia=inertia))
