"""Loading a user's own model (uvms.model.loader): the base rule, the totals, mounting an arm and saving the URDF,
xacro args, hydrodynamics.

A plain-root vehicle must not load silently as a fixed base, the root link's mass must count, a fixed base has no
generalized Jacobian, a mounted arm keeps the vehicle's end effectors and gives a URDF, bad xacro args name the arg,
and a hydrodynamics YAML typo names the file and the close link names.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.cli import main
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.plant.plant import Plant
from uvms.errors import BaseGuessWarning, NoVehicleError
from uvms.model import ADDED_BASE_JOINT

from conftest import ROOT, SHIPPED, shipped

EXAMPLE_HYDRODYNAMICS = ROOT / "models" / "example_hydrodynamics.yaml"


def inertial(mass: float) -> str:
    return (f'<inertial><mass value="{mass}"/><inertia ixx="{mass}" iyy="{mass}" izz="{mass}" ixy="0" ixz="0" '
            'iyz="0"/></inertial>')


def work_rov(root_mass: float | None = 1810.0, root: str = "hull") -> str:
    """A work-class ROV whose root link is the hull itself (no floating joint in the file): 1810 + 20 + 33 kg."""
    body = inertial(root_mass) if root_mass is not None else ""
    return f"""<robot name="workrov">
      <link name="{root}">{body}<visual><geometry><box size="2.5 1.5 1.6"/></geometry></visual></link>
      <link name="shoulder">{inertial(20.0)}</link>
      <link name="forearm">{inertial(33.0)}</link>
      <link name="camera_ee"/>
      <link name="tool_ee"/>
      <joint name="camera" type="fixed"><parent link="{root}"/><child link="camera_ee"/>
        <origin xyz="1.25 0 0.3"/></joint>
      <joint name="slew" type="revolute"><parent link="{root}"/><child link="shoulder"/>
        <origin xyz="1.2 0.4 -0.6"/><axis xyz="0 0 1"/><limit lower="-1.5" upper="1.5" effort="100" velocity="1"/>
      </joint>
      <joint name="elbow" type="revolute"><parent link="shoulder"/><child link="forearm"/>
        <origin xyz="0.5 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="100" velocity="1"/></joint>
      <joint name="tool" type="fixed"><parent link="forearm"/><child link="tool_ee"/><origin xyz="0.6 0 0"/></joint>
    </robot>"""


def load_quietly(source, **kwargs) -> uvms.Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BaseGuessWarning)
        return uvms.load(source, **kwargs)


def assert_same_model(a: uvms.Robot, b: uvms.Robot, rng: np.random.Generator) -> None:
    """Same sizes, joints, base, total mass and end-effector poses at random configurations (1e-12)."""
    assert (a.nq, a.nv, a.base_type) == (b.nq, b.nv, b.base_type)
    assert list(a.model.names) == list(b.model.names)
    assert a.total_mass == pytest.approx(b.total_mass, rel=1e-12)
    for _ in range(10):
        q = a.random_configuration(rng)
        for frame in a.ee_frames:
            np.testing.assert_allclose(a.fk(q, frame).homogeneous, b.fk(q, frame).homogeneous, atol=1e-12)


# ------------------------------------------------------------------ the base rule
def test_a_plain_root_link_with_mass_is_a_floating_vehicle_and_load_says_so():
    with pytest.warns(BaseGuessWarning, match="root link 'hull' carries 1810 kg; base='fixed' to hold it"):
        robot = uvms.load(work_rov())
    assert (robot.base_type, robot.n_vehicle, robot.n_arm) == ("floating", 6, 2)
    assert robot.joints[0].name == ADDED_BASE_JOINT and robot.joints[0].is_vehicle
    assert robot.base_reason == "floating (added: the root link 'hull' carries 1810 kg; base='fixed' to hold it)"
    assert robot.root_link == "hull"
    assert robot.total_mass == pytest.approx(1863.0, rel=1e-12)
    # a vehicle pose is accepted, and the vehicle reacts to the arm (momentum)
    q = robot.configuration(base=[1, 2, -30, 0.1, 0.0, 0.5], arm=[0.3, -0.2])
    assert robot.generalized_jacobian(q, "tool_ee").shape == (6, 2)
    assert np.linalg.norm(robot.base_velocity(q, np.array([1.0, 0.0]))) > 0


def test_base_overrides_the_rule_and_a_massless_root_is_a_fixed_arm():
    with warnings.catch_warnings():
        warnings.simplefilter("error", BaseGuessWarning)  # a base given is no guess: nothing to announce
        held = uvms.load(work_rov(), base="fixed")
        planar = uvms.load(work_rov(), base="planar")
        table = uvms.load(work_rov(root_mass=None, root="world"))
    assert (held.base_type, held.nq) == ("fixed", 2)
    assert held.base_reason == "fixed (base='fixed'; the root link 'hull' carries 1810 kg)"
    assert planar.base_type == "planar" and "added by base='planar'" in planar.base_reason
    assert (table.base_type, table.nq) == ("fixed", 2)
    assert table.base_reason.startswith("fixed (the root link 'world' has no mass")


def test_total_mass_keeps_the_root_link_of_a_fixed_base():
    held = load_quietly(work_rov(), base="fixed")
    # Pinocchio holds the fixed root link on the universe (inertias[0]), which pin.computeTotalMass leaves out
    assert held.model.inertias[0].mass == pytest.approx(1810.0)
    assert pin.computeTotalMass(held.model) == pytest.approx(53.0)
    assert held.total_mass == pytest.approx(1863.0, rel=1e-12)
    for name in SHIPPED:
        robot = shipped(name)
        assert robot.total_mass == pytest.approx(sum(inertia.mass for inertia in robot.model.inertias[1:]))


def test_uvms_info_states_the_base_rule_and_the_whole_mass(tmp_path, capsys):
    path = tmp_path / "workrov.urdf"
    path.write_text(work_rov())
    assert main(["info", str(path)]) == 0
    captured = capsys.readouterr()
    assert "base        floating: vehicle DOF 6, arm DOF 2" in captured.out
    assert ("base rule   floating (added: the root link 'hull' carries 1810 kg; base='fixed' to hold it)"
            in captured.out)
    assert "total mass  1863.000 kg" in captured.out
    assert main(["info", str(path), "--base", "fixed"]) == 0
    out = capsys.readouterr().out
    assert "base rule   fixed (base='fixed'; the root link 'hull' carries 1810 kg)" in out
    assert "total mass  1863.000 kg" in out
    assert main(["info", "hoang2011"]) == 0
    assert "base rule   planar (the file's root joint 'base_joint')" in capsys.readouterr().out


def test_vehicle_quantities_of_a_fixed_base_are_errors_that_point_to_jacobian():
    arm = load_quietly(work_rov(), base="fixed")
    q = arm.configuration(arm=[0.2, 0.1])
    assert arm.jacobian(q, "tool_ee").shape == (6, 2)
    for call in (lambda: arm.generalized_jacobian(q, "tool_ee"), lambda: arm.generalized_manipulability(q),
                 lambda: arm.base_velocity(q, np.ones(2)), lambda: arm.free_floating_velocity(q, np.ones(2)),
                 lambda: arm.base_velocity(q, np.ones(2), momentum=np.zeros(6)), lambda: arm.eta_ned(q)):
        with pytest.raises(NoVehicleError, match=r"fixed base .*no vehicle.*robot\.jacobian"):
            call()
    with pytest.raises(uvms.errors.ConfigurationError, match="fixed base .*base='fixed'.*give only arm values"):
        arm.configuration(base=[0, 0, 0, 0, 0, 0])


def test_shipped_models_and_example_arms_keep_their_base():
    with warnings.catch_warnings():
        warnings.simplefilter("error", BaseGuessWarning)
        for name in SHIPPED:
            robot = uvms.load(name)
            assert robot.base_reason == f"{robot.base_type} (the file's root joint 'base_joint')"
            assert robot.base_type in ("floating", "planar")
        for arm in ("ur5", "z1"):  # their root link 'world' has no mass: arms on a table, as before
            assert uvms.load(uvms.model.example_robot_urdf(arm)).base_type == "fixed"
    # panda's root link panda_link0 carries 0.63 kg: a free-flying body by the rule, base="fixed" bolts it down
    with pytest.warns(BaseGuessWarning, match="panda_link0"):
        assert uvms.load(uvms.model.example_robot_urdf("panda")).base_type == "floating"
    assert uvms.load(uvms.model.example_robot_urdf("panda"), base="fixed").nv == 8  # 7 joints + 1 finger (1 mimics)


# ------------------------------------------------------------------ mount_arm and the composed URDF
def test_mount_arm_defaults_to_the_root_link_and_keeps_every_end_effector():
    vehicle = load_quietly(work_rov(), ee=["tool_ee", "camera_ee"])
    robot = uvms.model.mount_arm(vehicle, "z1", placement=[1.0, -0.4, -0.7, np.pi, 0, 0])
    assert robot.ee_frames == ["tool_ee", "camera_ee", "arm_gripperMover"]
    assert robot.base_reason == vehicle.base_reason and robot.root_link == "hull"
    q = robot.random_configuration(3)
    arm = uvms.load(uvms.model.example_robot_urdf("z1"))
    expected = robot.fk(q, "hull") * uvms.robot.conventions.pose_from_xyzrpy([1.0, -0.4, -0.7, np.pi, 0, 0]) * arm.fk(
        q[vehicle.nq:], "gripperMover")
    np.testing.assert_allclose(robot.fk(q, "arm_gripperMover").homogeneous, expected.homogeneous, atol=1e-12)
    with pytest.raises(uvms.errors.FrameNotFound, match="unknown frame 'base_link'; close names: hull"):
        uvms.model.mount_arm(vehicle, "z1", parent_frame="base_link")
    bare = load_quietly(work_rov().replace('type="revolute"', 'type="fixed"'))  # a vehicle without arm joints
    assert uvms.model.mount_arm(bare, "z1").ee_frames[0] == "arm_gripperMover"  # the default end effector is the arm's


@pytest.mark.parametrize(("vehicle_name", "arm_name"), [("bluerov2_alpha5", "panda"), ("santos2006", "ur5"),
                                                        ("hoang2011", "z1"), ("workrov", "ur5")])
def test_the_composed_urdf_saved_loads_as_the_same_model(vehicle_name, arm_name, tmp_path, rng):
    vehicle = load_quietly(work_rov()) if vehicle_name == "workrov" else shipped(vehicle_name)
    robot = uvms.model.mount_arm(vehicle, arm_name, placement=[0.1, 0.0, -0.2, np.pi, 0.0, 0.3])
    assert robot.urdf is not None and "package://" not in robot.urdf
    saved = robot.save_urdf(tmp_path / "composed.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("error", BaseGuessWarning)  # the saved file states its base
        again = uvms.load(saved, ee=robot.ee_frames)
    assert_same_model(robot, again, rng)
    meshes = [mesh.get("filename") for mesh in again.urdf_root.iter("mesh")]
    assert all(Path(uri).is_absolute() and Path(uri).is_file() for uri in meshes)
    assert len(meshes) > 0 or arm_name == "z1"


@pytest.mark.parametrize("base", ["planar", "fixed", "floating"])
def test_save_urdf_states_a_base_given_to_load(base, tmp_path, rng):
    robot = load_quietly(work_rov(), base=base)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BaseGuessWarning)
        again = uvms.load(robot.save_urdf(tmp_path / "rov.urdf"), ee=robot.ee_frames)
    assert_same_model(robot, again, rng)
    mounted = uvms.model.mount_arm(robot, "z1", prefix="left_")
    twice = uvms.model.mount_arm(mounted, "z1", prefix="right_", placement=[0, 0.5, 0, 0, 0, 0])
    assert_same_model(twice, uvms.load(twice.save_urdf(tmp_path / "two.urdf"), ee=twice.ee_frames), rng)


def test_save_urdf_without_a_urdf_is_an_error(tmp_path):
    robot = uvms.Robot(shipped("hoang2011").model)
    with pytest.raises(uvms.UVMSError, match="has no URDF"):
        robot.save_urdf(tmp_path / "x.urdf")


# ------------------------------------------------------------------ xacro args and sizes
def test_a_non_numeric_xacro_arg_names_the_arg_and_asks_for_a_number(capsys):
    with pytest.raises(uvms.errors.XacroError, match=r"xacro arg l1='abc' is not a "
                                                     r"number.*default is 0\.4.*give a number"):
        uvms.load("hoang2011", args={"l1": "abc"})
    assert main(["info", "bluerov2_alpha5", "--arg", "vehicle_mass=heavy"]) == 2
    assert "xacro arg vehicle_mass='heavy' is not a number" in capsys.readouterr().err
    assert uvms.load("bluerov2_alpha5", args={"vehicle_volume": "trim"}).nv == 11  # a text arg stays a text arg


@pytest.mark.parametrize(("model", "args", "blamed", "element"), [
    ("hoang2011", {"l1": -0.4}, "l1", "link 'link1' visual <cylinder length='-0.4'>"),
    ("hoang2011", {"l3": 0.0, "l2": 0.5}, "l3", "link 'link3' visual <cylinder length='0"),
    ("santos2006", {"l2": -2.0}, "l2", "link 'link2' visual <cylinder length='-2"),
    ("bluerov2_alpha5", {"vehicle_length": -0.457}, "vehicle_length", "link 'base_link' visual <box size='-0.457"),
    ("bluerov2_alpha5", {"alpha_jaw_z": -0.1, "mount_x": -0.19}, "alpha_jaw_z", "link 'alpha_m1_link' visual <cyl"),
    ("xiang2019", {"a2": -0.37}, "a2", "link 'left_upper_arm' visual <cylinder length='-0.37'>"),
    ("hoang2011", {"vehicle_mass": -120}, "vehicle_mass", "link 'base_link' has mass -120 kg"),
])
def test_a_negative_length_or_mass_arg_is_refused_naming_the_element_and_the_arg(model, args, blamed, element):
    with pytest.raises(uvms.errors.ModelCheckError) as caught:
        uvms.load(model, args=args)
    message = str(caught.value)
    assert element in message and f"(from xacro arg {blamed}={args[blamed]!r}: with its default" in message
    innocent = set(args) - {blamed}  # a valid length, or a negative offset: a joint origin may be negative
    assert not any(f"{name}=" in message for name in innocent)


def test_geometry_sizes_of_any_urdf_must_be_positive():
    for bad, words in (('<box size="1 -2 1"/>', "<box size='1 -2 1'>"),
                       ('<cylinder radius="0" length="1"/>', "<cylinder radius='0'>"),
                       ('<sphere radius="-0.1"/>', "<sphere radius='-0.1'>")):
        with pytest.raises(uvms.errors.ModelCheckError, match=f"link 'hull' visual {words}: "
                                                              "a geometry size must be > 0"):
            uvms.load(work_rov().replace('<box size="2.5 1.5 1.6"/>', bad))


# ------------------------------------------------------------------ hydrodynamics
def test_a_link_typo_in_a_hydrodynamics_yaml_names_the_file_and_the_close_links(tmp_path):
    text = EXAMPLE_HYDRODYNAMICS.read_text()
    typo = tmp_path / "hydrodynamics.yaml"
    # a typo on a neutrally buoyant link: the name is checked before the mass the shortcut needs
    typo.write_text(text.replace("  alpha_m1_link:", "  alpha_m1_lnk:"))
    with pytest.raises(uvms.errors.NameNotFound, match=f"{typo}: unknown link .*'alpha_m1_lnk'; close names: "
                                                       "alpha_m1_link"):
        hydrodynamics_of(shipped("bluerov2_alpha5"), typo)
    (tmp_path / "rov.urdf").write_text(work_rov())
    (tmp_path / "hydrodynamics.yaml").write_text(
        "links:\n  hul:\n    neutrally_buoyant: true\n")  # beside the model
    with pytest.raises(uvms.errors.NameNotFound, match="hydrodynamics.yaml: unknown link .*'hul'; close names: hull"):
        hydrodynamics_of(load_quietly(tmp_path / "rov.urdf"))


def test_the_example_hydrodynamics_file_reaches_the_plant():
    robot = shipped("bluerov2_alpha5")
    hydro = hydrodynamics_of(robot, EXAMPLE_HYDRODYNAMICS)
    plant = Plant(robot, hydro, gravity=True)
    links = {link.name: link.params for link in plant.links}
    assert set(links) == {"base_link", "alpha_m1_link"}
    vehicle = links["base_link"]
    assert vehicle.volume == pytest.approx(0.0115)
    np.testing.assert_allclose(vehicle.center_of_buoyancy, [0.0, 0.0, 0.01])
    # SNAME (FRD) -> ROS (FLU): the surge-pitch coupling changes sign, the diagonal does not
    assert vehicle.added_mass[0, 4] == pytest.approx(-0.2) and vehicle.added_mass[4, 0] == pytest.approx(-0.2)
    np.testing.assert_allclose(np.diag(vehicle.added_mass), [6.36, 7.12, 18.68, 0.189, 0.135, 0.222])
    # Fossen's derivatives (<= 0) become damping coefficients (>= 0)
    np.testing.assert_allclose(vehicle.linear_damping, [13.7, 0.0, 33.0, 0.0, 0.8, 0.0])
    np.testing.assert_allclose(vehicle.quadratic_damping, [141.0, 217.0, 190.0, 1.19, 0.47, 1.5])
    m1_mass = float(robot.urdf_root.find("link[@name='alpha_m1_link']/inertial/mass").get("value"))
    assert links["alpha_m1_link"].volume == pytest.approx(m1_mass / 1028.0)  # neutrally buoyant
    np.testing.assert_allclose(plant.hydro.current, [0.1, 0.0, 0.0])
    # and the forces act: a surging vehicle in still water is braked by the drag the file gives
    still = Plant(robot, hydro.with_current([0.0, 0.0, 0.0]))
    v = np.zeros(robot.nv)
    v[0] = 1.0
    surge = still.evaluate(robot.neutral(), v, np.zeros(robot.n_arm)).acceleration[0]
    assert surge < -1.0
