"""ROS packages without ROS (uvms.model.packages): ``$(find pkg)`` and ``package://pkg/...`` resolve through the
package index, in the trusted expansion and in the sandbox alike.

The fixture workspace ``tests/fixtures/ros_ws/src`` holds a vehicle package whose xacro includes an arm macro from
another package by ``$(find fixture_arm_description)`` (that package's folder is ``fixture_arm``: the name comes
from its package.xml) and draws its hull by ``package://``, and a package beside a COLCON_IGNORE.
"""

from __future__ import annotations

import os
import shutil
import warnings

import numpy as np
import pytest
from xacro import substitution_args

import uvms
from uvms.cli import main
from uvms.errors import MissingMeshWarning, ModelFileNotFound, UVMSError, XacroError
from uvms.model import packages, resources, sandbox
from uvms.model.sandbox_worker import PackageNotFound, packages_for_find

from conftest import ROOT

WORKSPACE = ROOT / "tests" / "fixtures" / "ros_ws" / "src"
VEHICLE_PACKAGE = WORKSPACE / "fixture_vehicle_description"
ARM_PACKAGE = WORKSPACE / "fixture_arm"
VEHICLE = VEHICLE_PACKAGE / "urdf" / "vehicle.urdf.xacro"
#: The fixture's numbers: the arm's mount on the hull [m] and its two link lengths [m].
MOUNT = np.array([0.5, 0.0, -0.2])
FIXTURE_LENGTHS = (0.35, 0.25)
SANDBOX = [False] + ([True] if sandbox.confinement_problem() is None else [])
XACRO = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


@pytest.fixture(autouse=True)
def no_ros_environment(monkeypatch):
    """The tests name their packages themselves: a ROS environment of the machine stays out."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)


def expected_ee(pose: np.ndarray, arm: np.ndarray, lengths: tuple[float, float]) -> np.ndarray:
    """The end effector of the fixture vehicle in closed form: hull at (x, y, z) turned by yaw, the planar two-link
    arm about z mounted at MOUNT [m]."""
    x, y, z, yaw = pose[0], pose[1], pose[2], pose[5]
    upper, fore = lengths
    q1, q12 = arm[0], arm[0] + arm[1]
    in_hull = MOUNT + [upper * np.cos(q1) + fore * np.cos(q12), upper * np.sin(q1) + fore * np.sin(q12), 0.0]
    turn = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    return np.array([x, y, z]) + turn @ in_hull


def assert_arm_lengths(robot: uvms.Robot, lengths: tuple[float, float], rng: np.random.Generator) -> None:
    """FK of the loaded model equals the closed form of an arm of ``lengths``, at random configurations."""
    assert robot.n_arm == 2
    for _ in range(5):
        pose = np.concatenate([rng.uniform(-2, 2, 3), [0.0, 0.0], rng.uniform(-np.pi, np.pi, 1)])
        arm = rng.uniform(-2.5, 2.5, 2)
        q = robot.configuration(base=pose, arm=arm)
        np.testing.assert_allclose(robot.fk(q, "ee").translation, expected_ee(pose, arm, lengths), atol=1e-12)


def arm_package(folder, name: str, lengths: tuple[float, float]):
    """A copy of the fixture's arm package named ``name`` (in its package.xml) with other link lengths."""
    shutil.copytree(ARM_PACKAGE, folder)
    (folder / "package.xml").write_text(f"<package format='3'><name>{name}</name></package>")
    text = (folder / "urdf" / "arm.xacro").read_text()
    text = text.replace('value="0.35"', f'value="{lengths[0]}"').replace('value="0.25"', f'value="{lengths[1]}"')
    (folder / "urdf" / "arm.xacro").write_text(text)
    return folder


def loose_vehicle(tmp_path):
    """The fixture vehicle's xacro copied to a folder that is in no package (no workspace to walk up to)."""
    (tmp_path / "loose").mkdir()
    return shutil.copy(VEHICLE, tmp_path / "loose" / "vehicle.urdf.xacro")


# ------------------------------------------------------------------ the model's own workspace
@pytest.mark.parametrize("untrusted", SANDBOX)
def test_a_model_in_a_workspace_finds_its_packages_by_walking_up(untrusted, rng):
    with warnings.catch_warnings():
        warnings.simplefilter("error", MissingMeshWarning)  # the package:// hull is found
        robot = uvms.load(VEHICLE, trusted=not untrusted)
    assert_arm_lengths(robot, FIXTURE_LENGTHS, rng)  # the arm really came from the other package
    assert robot.packages["fixture_arm_description"] == ARM_PACKAGE  # named by its package.xml, not its folder
    assert robot.packages["fixture_vehicle_description"] == VEHICLE_PACKAGE
    assert "fixture_arm" not in robot.packages and "fixture_ignored_description" not in robot.packages
    hull = "package://fixture_vehicle_description/meshes/hull.stl"
    assert resources.resolve_uri(hull, None, robot.packages) == VEHICLE_PACKAGE / "meshes" / "hull.stl"


def test_the_viewer_finds_the_meshes_through_the_packages_the_robot_was_loaded_with():
    from uvms.model.meshes import resolved_urdf

    xml, missing = resolved_urdf(uvms.load(VEHICLE, trusted=True))
    assert missing == [] and str(VEHICLE_PACKAGE / "meshes" / "hull.stl") in xml and "package://" not in xml


def test_the_workspace_is_the_src_above_the_model_s_package_else_the_package_itself(tmp_path):
    assert packages.model_workspace(VEHICLE) == WORKSPACE
    own_src = tmp_path / "ws" / "src" / "pkg" / "src" / "urdf"  # a package's own src/ is not a workspace
    own_src.mkdir(parents=True)
    (tmp_path / "ws" / "src" / "pkg" / "package.xml").write_text("<package><name>pkg</name></package>")
    assert packages.model_workspace(own_src / "m.urdf") == tmp_path / "ws" / "src"
    (tmp_path / "downloads" / "rov_description" / "urdf").mkdir(parents=True)
    (tmp_path / "downloads" / "rov_description" / "package.xml").write_text("<package><name>rov</name></package>")
    assert packages.model_workspace(tmp_path / "downloads" / "rov_description" / "urdf" / "m.urdf") == (
        tmp_path / "downloads" / "rov_description")  # no src above: its own package, not the folder beside it
    assert packages.model_workspace(tmp_path / "downloads" / "m.urdf") is None  # in no package: no workspace
    assert packages.model_workspace(resources.shipped_models()["hoang2011"]) is None


SECRET = "uvms-test-secret-19"
#: A downloaded vehicle that reads a YAML file of another package by $(find) (or by a relative path) into a link name.
READS_SECRET = f"""<robot name="rov" {XACRO}>
  <xacro:property name="creds" value="${{xacro.load_yaml('{{path}}')}}"/>
  <link name="world"/>
  <link name="hull_${{creds['token']}}"><inertial><mass value="1"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull_${{creds['token']}}"/></joint>
</robot>"""


def downloads_folder(tmp_path, path: str):
    """downloads/{secret_pkg (config/creds.yaml), rov_description (urdf/rov.urdf.xacro reading ``path``)}: two
    packages side by side in a folder that is no workspace (no src); the model's file."""
    downloads = tmp_path / "downloads"
    for name in ("secret_pkg", "rov_description"):
        (downloads / name).mkdir(parents=True)
        (downloads / name / "package.xml").write_text(f"<package><name>{name}</name></package>")
    (downloads / "secret_pkg" / "config").mkdir()
    (downloads / "secret_pkg" / "config" / "creds.yaml").write_text(f"token: {SECRET}\n")
    (downloads / "rov_description" / "urdf").mkdir()
    model = downloads / "rov_description" / "urdf" / "rov.urdf.xacro"
    model.write_text(READS_SECRET.replace("{path}", path))
    return model


@pytest.mark.parametrize("untrusted", SANDBOX)
def test_a_downloaded_package_does_not_find_the_packages_beside_it(tmp_path, monkeypatch, untrusted, capsys):
    """The finding: $(find secret_pkg) of a model unpacked beside it read its credentials into `uvms info`."""
    model = downloads_folder(tmp_path, "$(find secret_pkg)/config/creds.yaml")
    with pytest.raises(XacroError) as raised:
        uvms.load(model, trusted=not untrusted)
    message = str(raised.value)
    assert "no ROS package 'secret_pkg'" in message and SECRET not in message
    assert f"the model's own package {model.parents[1]} (no workspace: no src folder above it)" in message
    assert main(["info", str(model)]) == 2
    said = capsys.readouterr()
    assert SECRET not in said.out + said.err and said.err.count("\n") == 1
    for named in ([model.parents[2] / "secret_pkg"], [model.parents[2]]):  # the user's choice: then it may
        assert f"hull_{SECRET}" in uvms.load(model, trusted=not untrusted, package_path=named).frame_names
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(model.parents[2]))
    assert f"hull_{SECRET}" in uvms.load(model, trusted=not untrusted).frame_names


@pytest.mark.skipif(sandbox.confinement_problem() is not None or sandbox.landlock_abi() == 0,
                    reason="needs the sandbox with Landlock")
def test_a_downloaded_package_cannot_read_the_packages_beside_it_by_path(tmp_path):
    model = downloads_folder(tmp_path, "../../secret_pkg/config/creds.yaml")
    with pytest.raises(XacroError, match="may read only") as raised:
        uvms.load(model)  # a file from outside the shipped models: untrusted, in the sandbox
    assert SECRET not in str(raised.value)


def test_a_package_in_a_workspace_still_finds_its_siblings(tmp_path, rng):
    workspace = tmp_path / "ws" / "src"
    shutil.copytree(WORKSPACE, workspace)
    model = workspace / "fixture_vehicle_description" / "urdf" / "vehicle.urdf.xacro"
    assert packages.model_workspace(model) == workspace
    robot = uvms.load(model, trusted=True)
    assert robot.packages["fixture_arm_description"] == workspace / "fixture_arm"
    assert_arm_lengths(robot, FIXTURE_LENGTHS, rng)


# ------------------------------------------------------------------ the folders a user names
@pytest.mark.parametrize("untrusted", SANDBOX)
def test_a_model_outside_its_packages_needs_them_named(tmp_path, monkeypatch, untrusted, rng):
    model = loose_vehicle(tmp_path)
    with pytest.raises(XacroError) as raised:
        uvms.load(model, trusted=not untrusted)
    message = str(raised.value)
    assert len(message.splitlines()) == 1 and "Traceback" not in message
    for said in ("$(find fixture_arm_description)", "no ROS package 'fixture_arm_description'", "no ROS_PACKAGE_PATH",
                 "no workspace", "found 1: example-robot-data", "--package-path DIR", "package_path=",
                 "ROS_PACKAGE_PATH"):
        assert said in message, said
    for named in ([WORKSPACE.parent], [ARM_PACKAGE, VEHICLE_PACKAGE], [str(WORKSPACE)]):  # searched, or packages
        assert_arm_lengths(uvms.load(model, package_path=named, trusted=not untrusted), FIXTURE_LENGTHS, rng)
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'absent'}{os.pathsep}{WORKSPACE}")  # absent: skipped
    assert_arm_lengths(uvms.load(model, trusted=not untrusted), FIXTURE_LENGTHS, rng)


def test_the_first_package_in_precedence_wins(tmp_path, monkeypatch, rng):
    named = arm_package(tmp_path / "named" / "arm", "fixture_arm_description", (0.5, 0.1))
    prefix = tmp_path / "install"
    arm_package(prefix / "share" / "fixture_arm_description", "renamed_in_its_xml", (0.6, 0.2))  # named by folder
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    assert_arm_lengths(uvms.load(VEHICLE, trusted=True), (0.6, 0.2), rng)  # an install tree before the workspace
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(WORKSPACE))
    assert_arm_lengths(uvms.load(VEHICLE, trusted=True), FIXTURE_LENGTHS, rng)  # ROS_PACKAGE_PATH before ament
    assert_arm_lengths(uvms.load(VEHICLE, trusted=True, package_path=[named]), (0.5, 0.1), rng)  # the user's first
    index = packages.package_index([named.parent], VEHICLE)
    assert list(index)[:2] == ["fixture_arm_description", "fixture_vehicle_description"]
    assert index["fixture_arm_description"] == named


def test_find_inside_eval_resolves_through_the_index_too():
    # xacro 2.1's lexer ends a $(...) at its first ")", so a file cannot spell find('pkg') inside $(eval ...); the
    # substitution itself, which xacro's own find serves as well, answers from the index
    index = {"fixture_arm_description": ARM_PACKAGE}
    with packages_for_find(index):
        assert substitution_args.resolve_args("$(eval find('fixture_arm_description') + '/urdf')") == (
            f"{ARM_PACKAGE}/urdf")
        assert substitution_args.resolve_args("$(find fixture_arm_description)/urdf") == f"{ARM_PACKAGE}/urdf"
        with pytest.raises(PackageNotFound):
            substitution_args.resolve_args("$(eval find('fixture_vehicle_description'))")


def test_xacro_s_own_find_is_back_after_an_expansion_that_succeeds_or_fails(tmp_path):
    before = substitution_args._eval_find, substitution_args._eval_dict["find"]
    uvms.load(VEHICLE, trusted=True)
    with pytest.raises(XacroError):
        uvms.load(loose_vehicle(tmp_path), trusted=True)
    assert (substitution_args._eval_find, substitution_args._eval_dict["find"]) == before


def test_named_folders_must_exist_and_be_a_list(tmp_path):
    with pytest.raises(ModelFileNotFound, match="absent.* does not exist; package_path names folders"):
        uvms.load(VEHICLE, package_path=[tmp_path / "absent"])
    (tmp_path / "file").write_text("")
    with pytest.raises(ModelFileNotFound, match="is not a folder"):
        packages.package_index([tmp_path / "file"])
    with pytest.raises(UVMSError, match="must be a list of folders.*write \\["):
        uvms.load(VEHICLE, package_path=str(WORKSPACE))


# ------------------------------------------------------------------ the sandbox reads only the indexed packages
@pytest.mark.skipif(sandbox.confinement_problem() is not None or sandbox.landlock_abi() == 0,
                    reason="needs the sandbox with Landlock")
def test_the_sandbox_cannot_read_a_package_that_is_not_indexed(tmp_path):
    other = tmp_path / "other" / "secret_description"
    (other / "urdf").mkdir(parents=True)
    (other / "package.xml").write_text("<package><name>secret_description</name></package>")
    (other / "urdf" / "part.xacro").write_text(f'<robot {XACRO}><link name="secret_part"/><joint name="s" type="fixed">'
                                               '<parent link="a"/><child link="secret_part"/></joint></robot>')
    model = tmp_path / "model" / "m.urdf.xacro"
    model.parent.mkdir()
    model.write_text(f'<robot name="m" {XACRO}><link name="world"/><link name="a"><inertial><mass value="1"/>'
                     '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
                     '<joint name="j" type="revolute"><parent link="world"/><child link="a"/><axis xyz="0 0 1"/>'
                     '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
                     f'<xacro:include filename="{other / "urdf" / "part.xacro"}"/></robot>')
    with pytest.raises(XacroError, match="Permission denied.*may read only") as raised:
        uvms.load(model, trusted=False)
    assert len(str(raised.value).splitlines()) == 1
    assert "secret_part" in uvms.load(model, trusted=False, package_path=[tmp_path / "other"]).urdf
    assert "secret_part" in uvms.load(model, trusted=True).urdf  # a trusted file reads what its user can


# ------------------------------------------------------------------ the search
def test_ignored_and_hidden_folders_are_not_searched(tmp_path):
    found = packages.find_packages(WORKSPACE)
    assert found == {"fixture_vehicle_description": VEHICLE_PACKAGE, "fixture_arm_description": ARM_PACKAGE}
    for marker, folder in (("CATKIN_IGNORE", "a"), ("AMENT_IGNORE", "b/deeper")):
        (tmp_path / folder / "pkg").mkdir(parents=True)
        (tmp_path / folder / "pkg" / "package.xml").write_text(f"<package><name>{marker}_pkg</name></package>")
        (tmp_path / folder / marker).write_text("")
    (tmp_path / ".hidden" / "pkg").mkdir(parents=True)
    (tmp_path / ".hidden" / "pkg" / "package.xml").write_text("<package><name>hidden_pkg</name></package>")
    (tmp_path / "c" / "kept").mkdir(parents=True)
    (tmp_path / "c" / "kept" / "package.xml").write_text("<package><name>kept_pkg</name></package>")
    assert packages.find_packages(tmp_path) == {"kept_pkg": tmp_path / "c" / "kept"}


def test_symbolic_links_loop_or_lead_out_of_the_tree_without_harm(tmp_path):
    tree = tmp_path / "tree"
    (tree / "pkgs" / "inner").mkdir(parents=True)
    (tree / "pkgs" / "inner" / "package.xml").write_text("<package><name>inner</name></package>")
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "package.xml").write_text("<package><name>outside</name></package>")
    (tree / "pkgs" / "loop").symlink_to(tree)  # back up: a loop
    (tree / "self").symlink_to(tree / "self")  # a link to itself (ELOOP)
    (tree / "out").symlink_to(tmp_path / "outside")  # out of the searched tree: not followed
    (tree / "again").symlink_to(tree / "pkgs")  # inside the tree: followed, each folder once
    assert packages.find_packages(tree) == {"inner": tree / "pkgs" / "inner"}  # by its real path
    assert packages.find_packages(tree / "out") == {"outside": tmp_path / "outside"}  # a link named is followed


def test_the_search_is_bounded_in_depth_and_folders(tmp_path, monkeypatch):
    deep = tmp_path / "d1" / "d2" / "d3" / "pkg"
    deep.mkdir(parents=True)
    (deep / "package.xml").write_text("<package><name>deep</name></package>")
    assert packages.find_packages(tmp_path) == {"deep": deep}
    monkeypatch.setattr(packages, "MAX_PACKAGE_DEPTH", 3)
    assert packages.find_packages(tmp_path) == {}  # the package lies 4 levels down
    monkeypatch.setattr(packages, "MAX_PACKAGE_DEPTH", 16)
    for k in range(10):
        (tmp_path / f"wide{k}").mkdir()
    monkeypatch.setattr(packages, "MAX_PACKAGE_FOLDERS", 5)
    with pytest.warns(packages.PackageSearchWarning, match="stopped searching for ROS packages after 5 folders"):
        assert packages.find_packages(tmp_path) == {}


def test_a_package_is_named_by_its_package_xml_else_by_its_folder(tmp_path):
    cases = {"named": "<package><name> real_name </name></package>",
             "unnamed": "<package><version>1</version></package>",
             "odd": "<package><name>not/a/name</name></package>"}
    for folder, text in cases.items():
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "package.xml").write_text(text)
    assert packages.find_packages(tmp_path) == {"real_name": tmp_path / "named", "unnamed": tmp_path / "unnamed",
                                                "odd": tmp_path / "odd"}
    bombs = {"broken": "<package><name>x</name>", "entity": '<!DOCTYPE p [<!ENTITY a '
                                                            '"aaaa">]><package><name>&a;</name></package>',
             "huge": "<package><name>x</name>" + " " * packages.MAX_PACKAGE_XML_BYTES + "</package>"}
    for folder, text in bombs.items():
        (tmp_path / "bad" / folder).mkdir(parents=True)
        (tmp_path / "bad" / folder / "package.xml").write_text(text)
        with pytest.warns(packages.PackageSearchWarning, match=f"{folder}/package.xml: cannot read the package name"):
            assert packages.find_packages(tmp_path / "bad" / folder) == {folder: tmp_path / "bad" / folder}


def test_two_packages_of_one_name_in_one_tree_keep_the_shallower_with_a_warning(tmp_path):
    for folder in ("a/deep/twin", "b"):
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / "package.xml").write_text("<package><name>twin</name></package>")
    with pytest.warns(packages.PackageSearchWarning, match="two ROS packages named 'twin'"):
        assert packages.find_packages(tmp_path) == {"twin": tmp_path / "b"}


def test_the_includes_of_a_package_are_walked_through_the_index():
    """``$(find pkg)/...`` includes are followed (the arg check and --watch see the other package's files)."""
    from uvms.model.includes import walk_xacro
    from uvms.model.packages import package_index
    from uvms.scenario.watch import model_files

    model = ROOT / "tests" / "fixtures" / "uuv_ws" / "src" / "fixture_uuv_rov" / "urdf" / "rov.urdf.xacro"
    arm = ROOT / "tests" / "fixtures" / "uuv_ws" / "src" / "fixture_uuv_arm" / "urdf" / "arm.xacro"
    assert walk_xacro(model).args is None  # without the index the includes are computed names: xacro checks
    walk = walk_xacro(model, package_index(None, model))
    assert walk.args == {"namespace": "rov"} and arm.resolve() in walk.files
    assert arm.resolve() in model_files(model)
    with pytest.raises(uvms.errors.XacroError, match=r"unknown xacro arg\(s\) namespce; "
                                                     r"this model declares: namespace$"):
        uvms.load(model, args={"namespce": "x"})
