"""Bad inputs: each raises its uvms.UVMSError subclass with a useful message; the CLI exits 2 with one line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import uvms
from uvms.cli import main

from conftest import FLOATING_ROOT, shipped, urdf


def test_a_valid_user_urdf_loads(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(urdf())
    robot = uvms.load(path)
    assert (robot.base_type, robot.nq, robot.ee_frames) == ("fixed", 1, ["l1"])
    assert uvms.load(path, base="floating").nv == 7
    assert uvms.load(urdf(root=FLOATING_ROOT)).base_type == "floating"


@pytest.mark.parametrize(
    ("source", "error", "words"),
    [
        ("/nonexistent/robot.urdf", uvms.errors.ModelFileNotFound, "does not exist"),
        ("<robot name='x'><link name='a'></robot>", uvms.errors.ModelParseError, "malformed XML"),
        ("<model/>", uvms.errors.ModelParseError, "needs <robot>"),
        (urdf(axis="0 0 0"), uvms.errors.ModelCheckError, "zero axis"),
        (urdf(axis="0 0 2"), uvms.errors.ModelCheckError, "unit vectors"),
        (urdf(xyz="nan 0 0"), uvms.errors.ModelCheckError, "not finite"),
        (urdf(xyz="inf 0 0"), uvms.errors.ModelCheckError, "not finite"),
        (urdf(xyz="1 0"), uvms.errors.ModelCheckError, "expected 3"),
        (urdf(mass="-2"), uvms.errors.ModelCheckError, "must be positive"),
        (urdf(mass="0"), uvms.errors.ModelCheckError, "must be positive"),
        (urdf(ixx="-1"), uvms.errors.ModelCheckError, "not positive definite"),
        (urdf(extra='<joint name="j2" type="fixed"><parent link="l1"/><child link="base_link"/></joint>'),
         uvms.errors.ModelCheckError, "cycle"),
        (urdf(extra='<link name="l2"/><joint name="j2" type="fixed"><parent link="l1"/><child link="l2"/></joint>'
                    '<joint name="j3" type="fixed"><parent link="base_link"/><child link="l2"/></joint>'),
         uvms.errors.ModelCheckError, "child of two joints"),
        (urdf(extra='<link name="orphan"/>'), uvms.errors.ModelCheckError, "2 roots"),
        (urdf(root='<link name="world"/><joint name="p" type="planar"><parent link="world"/>'
                   '<child link="base_link"/><axis xyz="1 0 0"/></joint>'), uvms.errors.ModelCheckError, "x-y plane"),
    ],
)
def test_bad_model_raises_its_error(source, error, words):
    with pytest.raises(error, match=words):
        uvms.load(source)


def test_massless_link_idiom_is_accepted():
    assert uvms.load(urdf(extra='<link name="tip"><inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" '
                               'ixz="0" iyz="0"/></inertial></link><joint name="t" type="fixed"><parent link="l1"/>'
                               '<child link="tip"/></joint>')).nq == 1


@pytest.mark.parametrize(
    ("content", "args", "words"),
    [
        ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"><visual><geometry>'
         '<box size="${w} 1 1"/></geometry></visual></link></robot>', {}, "name 'w' is not defined"),
        ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"><visual><geometry>'
         '<box size="$(arg w) 1 1"/></geometry></visual></link></robot>', {}, "Undefined substitution argument w"),
        ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:include '
         'filename="missing.xacro"/></robot>',
         {}, "No such file"),
        ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:arg '
         'name="w" default="1"/><link name="a"/></robot>',
         {"width": 2}, "unknown xacro arg"),
    ],
)
def test_xacro_errors(tmp_path, content, args, words):
    path = tmp_path / "bad.urdf.xacro"
    path.write_text(content)
    with pytest.raises(uvms.errors.XacroError, match=words):
        uvms.load(path, args=args)


def test_base_that_contradicts_the_file():
    with pytest.raises(uvms.errors.BaseMismatchError, match="contradicts"):
        uvms.load("hoang2011", base="floating")
    with pytest.raises(uvms.errors.BaseMismatchError):
        uvms.load("xiang2019", base="fixed")
    with pytest.raises(uvms.UVMSError, match="valid: floating, planar, fixed"):
        uvms.load("hoang2011", base="flying")


def test_unknown_frame_lists_close_names():
    robot = shipped("xiang2019")
    with pytest.raises(uvms.errors.FrameNotFound, match="close names: left_ee"):
        robot.fk(robot.neutral(), "left_e")
    with pytest.raises(uvms.errors.FrameNotFound):
        uvms.load("hoang2011", ee="tool")


def test_a_model_name_or_none_where_a_robot_is_needed_says_how_to_get_one():
    """Every public entry that takes the model refuses what is not one (a UVMSError and a TypeError), by name."""
    robot = shipped("hoang2011")
    task = uvms.FrameTask(robot, axes=["x", "y", "yaw"], target=robot.fk(robot.neutral()))
    calls = {"FrameTask": lambda r: uvms.FrameTask(r), "MidRangePotential": uvms.tasks.MidRangePotential,
             "VehicleTask": uvms.VehicleTask, "Plant": uvms.Plant, "CLIK": lambda r: uvms.CLIKSolver(r, task),
             "solve_ik": lambda r: uvms.solve_ik(r, [0, 0, 0, 0, 0, 0]), "Configuration": lambda r: uvms.Configuration(
                 r, robot.neutral()), "initial_configuration": lambda r: uvms.solvers.initial_configuration(r, task),
             "thrusters_of": uvms.dynamics.thrusters_of, "hydrodynamics_of": uvms.dynamics.hydrodynamics_of,
             "BatchKinematics": lambda r: uvms.workspace.BatchKinematics(r, "ee")}
    for where, call in calls.items():
        with pytest.raises(uvms.errors.NotARobot, match=rf"^{where} needs a uvms.Robot .*got str 'hoang2011': "
                                                 r"uvms.load\('hoang2011'\) loads that model"):
            call("hoang2011")
        with pytest.raises(TypeError, match=f"^{where} needs a uvms.Robot .*got NoneType None$"):
            call(None)


def test_tasks_and_targets_that_are_not_numbers_are_refused_by_what_is_valid():
    robot = shipped("hoang2011")
    with pytest.raises(uvms.errors.SolverInputError, match="expected a Task or a sequence of Tasks, got None"):
        uvms.CLIKSolver(robot, None)
    with pytest.raises(uvms.UVMSError, match=r"a target pose must be a pin.SE3 or 6 finite numbers .* got 'x'"):
        uvms.solve_ik(robot, "x")
    with pytest.raises(uvms.UVMSError, match=r"a target twist must be 6 finite numbers .* got \[1, 'a'\]"):
        uvms.FrameTask(robot).set_target_velocity([1, "a"])


@pytest.mark.parametrize(
    "q",
    [np.zeros(3), np.full(7, np.nan), [0, 0, 1, 0, 0, 0, "x"], np.array([0, 0, 2.0, 0, 0, 0, 0])],
)
def test_bad_configuration(q):
    robot = shipped("hoang2011")
    with pytest.raises(uvms.errors.ConfigurationError):
        robot.fk(q)


def test_bad_arm_values_and_base_pose():
    robot = shipped("hoang2011")
    with pytest.raises(uvms.errors.ConfigurationError, match=r"shape \(3,\)"):
        robot.configuration(arm=[1.0, 2.0])
    with pytest.raises(uvms.errors.ConfigurationError, match="non-finite"):
        robot.configuration(base=[0.0, np.inf, 0.0])
    with pytest.raises(uvms.errors.ConfigurationError, match=r"shape \(3,\)"):
        robot.base_velocity(robot.neutral(), [1.0])


def run_cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "uvms.cli", *argv], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(
    "argv",
    [
        ("info", "/nonexistent.urdf"),
        ("info", "hoang2011", "--arg", "nosuch=1"),
        ("info", "hoang2011", "--arg", "novalue"),
        ("info", "hoang2011", "--base", "floating"),
        ("info", "hoang2011", "--ee", "tool"),
        ("info",),
        ("frobnicate",),
    ],
)
def test_cli_errors_are_one_line_and_exit_2(argv):
    result = run_cli(*argv)
    assert result.returncode == 2
    assert result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr


def test_cli_malformed_file(tmp_path, capsys):
    path = tmp_path / "broken.urdf"
    path.write_text("<robot name='x'><link name='a'>")
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "malformed XML" in err


def test_missing_meshes_only_warn_and_package_path_resolves_them(tmp_path):
    mesh_link = ('<link name="shell"><visual><geometry><mesh filename="package://my_rov/meshes/hull.stl"/>'
                 '</geometry></visual></link><joint name="s" '
                 'type="fixed"><parent link="l1"/><child link="shell"/></joint>')
    source = urdf(extra=mesh_link)
    with pytest.warns(uvms.errors.MissingMeshWarning, match="package://my_rov/meshes/hull.stl"):
        assert uvms.load(source).nq == 1
    (tmp_path / "my_rov" / "meshes").mkdir(parents=True)
    (tmp_path / "my_rov" / "meshes" / "hull.stl").write_text("solid hull\nendsolid hull\n")
    (tmp_path / "my_rov" / "package.xml").write_text("<package><name>my_rov</name></package>")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", uvms.errors.MissingMeshWarning)
        assert uvms.load(source, package_path=[tmp_path]).nq == 1
        assert uvms.load(source, package_path=[tmp_path / "my_rov"]).nq == 1
        uvms.model.mount_arm(shipped("hoang2011"), "panda")  # example-robot-data meshes are found


@pytest.mark.parametrize(
    "source",
    [urdf(axis="0 0 0"), urdf(xyz="nan 0 0"), urdf(mass="-2"), urdf(ixx="-1"), urdf(extra='<link name="orphan"/>'),
     "<robot name='x'><link name='a'></robot>"],
)
def test_bad_models_through_the_cli_are_one_line(tmp_path, capsys, source):
    path = tmp_path / "bad.urdf"
    path.write_text(source)
    assert main(["info", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1 and "Traceback" not in captured.err


def test_continuous_joint_is_an_angle_for_the_user_and_cos_sin_for_pinocchio():
    robot = uvms.load(urdf().replace('type="revolute"', 'type="continuous"').replace(
        '<limit lower="-1" upper="1" effort="1" velocity="1"/>', ""))
    assert (robot.nq, robot.nv) == (2, 1)
    q = robot.configuration(arm=[2.5])  # beyond pi/2: (cos, sin) keeps the angle unambiguous
    assert q == pytest.approx([np.cos(2.5), np.sin(2.5)])
    assert robot.arm_configuration(q) == pytest.approx([2.5])
    assert robot.jacobian(q).shape == (6, 1)
    with pytest.raises(uvms.errors.ConfigurationError):
        robot.fk([2.0, 0.0])  # not a unit (cos, sin) pair


def test_unreadable_model_path_is_a_directory(tmp_path):
    folder = tmp_path / "robot.urdf"
    folder.mkdir()
    with pytest.raises(uvms.errors.ModelFileNotFound, match="is not a file"):
        uvms.load(folder)


def test_a_model_without_any_degree_of_freedom_is_refused():
    fixed_only = urdf().replace('type="revolute"', 'type="fixed"')
    with pytest.raises(uvms.errors.ModelCheckError, match="no degree of freedom"):
        uvms.load(fixed_only)
    assert uvms.load(fixed_only, base="floating").nv == 6  # the same tree on a vehicle is fine
