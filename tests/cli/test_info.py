"""`uvms info` (uvms.cli.info) on every shipped model and on a URDF a user writes; every line the CLI prints is
escaped."""

from __future__ import annotations

import json
import re

import pytest

from uvms.cli import main

from conftest import ESCAPES, FLOATING_ROOT, ROOT, ROS_WORKSPACE, SHIPPED, one_line, raising, urdf

SANTOS = ROOT / "scenarios" / "santos2006_task_priority.toml"


@pytest.mark.parametrize("name", SHIPPED)
def test_info_on_shipped_models(name, capsys):
    assert main(["info", name]) == 0
    out = capsys.readouterr().out
    assert "checks      passed" in out
    assert re.search(r"total mass  \d+\.\d{3} kg", out)


def test_info_on_a_user_urdf(tmp_path, capsys):
    path = tmp_path / "my_rov.urdf"
    path.write_text(urdf(root=FLOATING_ROOT))
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "floating: vehicle DOF 6, arm DOF 1" in out
    assert "total mass  2.000 kg" in out
    assert main(["info", str(path).replace("my_rov.urdf", "my_rov.urdf"), "--ee", "base_link"]) == 0


def test_info_xacro_args_change_the_model(capsys):
    assert main(["info", "hoang2011"]) == 0
    default = capsys.readouterr().out
    assert main(["info", "hoang2011", "--arg", "l1=1.0", "--arg", "vehicle_mass=200"]) == 0
    changed = capsys.readouterr().out
    assert "xyz [ 0.4 -1.7  0. ]" in default and "xyz [ 0.4 -2.3  0. ]" in changed
    assert "total mass  209.000 kg" in changed


def test_info_base_option_adds_a_vehicle(tmp_path, capsys):
    path = tmp_path / "arm.urdf"
    path.write_text(urdf())
    assert main(["info", str(path), "--base", "planar"]) == 0
    assert "planar: vehicle DOF 3, arm DOF 1" in capsys.readouterr().out


# ------------------------------------------------------------------ terminal escapes never reach the terminal
def test_control_characters_never_reach_the_terminal(tmp_path, monkeypatch, capsys):
    scenario = tmp_path / "evil.toml"
    key = json.dumps(ESCAPES)  # a TOML basic string: \u001b...
    scenario.write_text(SANTOS.read_text().replace('"../models', f'"{ROOT}/models').replace(
        "[solver]", f"[solver]\n{key} = 1"))
    assert main(["run", str(scenario), "--out", str(tmp_path / "out")]) == 2
    err = one_line(capsys)
    assert "unknown key(s) solver.\\x1b]52;c;ZWNobyBwd25lZA==\\x07\\x1b[2K" in err
    assert not any(ord(c) < 32 or 0x7f <= ord(c) <= 0x9f for c in err.rstrip("\n"))
    assert main(["run", str(SANTOS), "--out", str(tmp_path / "out"), "--set", "solver.\u202egain\u2066=1"]) == 2
    err = one_line(capsys)
    assert "solver.\\u202egain\\u2066" in err and "\u202e" not in err and "\u2066" not in err

    monkeypatch.setattr("uvms.cli.command_info", raising(RuntimeError("\x9b2J\x7f\x1b[31m")))  # internal error
    assert main(["info", "hoang2011"]) == 2
    assert "RuntimeError: \\x9b2J\\x7f\\x1b[31m" in one_line(capsys)
    stop = KeyboardInterrupt()
    stop.add_note("nothing was written to out/\x1b[2K")
    monkeypatch.setattr("uvms.cli.command_info", raising(stop))  # and the interrupt note
    assert main(["info", "hoang2011"]) == 130
    assert capsys.readouterr().err == "uvms: interrupted; nothing was written to out/\\x1b[2K\n"
    from uvms.cli import printable  # the one function every line goes through

    assert printable("a\tb\u202cc\u2069") == "a\\x09b\\u202cc\\u2069"


def test_names_from_a_model_reach_the_terminal_escaped(tmp_path, capsys):
    """uvms info prints link and joint names from a stranger's URDF: a bidi override (XML allows it, unlike C0
    controls) arrives escaped, so a name cannot reorder what the terminal shows."""
    evil = "arm\u202egpj.exe\u2066"
    urdf = tmp_path / "evil.urdf"
    urdf.write_text(f"""<robot name="r{evil}">
  <link name="hull"><inertial><mass value="10"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="{evil}"><inertial><mass value="1"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j{evil}" type="revolute"><parent link="hull"/><child link="{evil}"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""")
    assert main(["info", str(urdf)]) == 0
    captured = capsys.readouterr()
    assert "\u202e" not in captured.out + captured.err and "\u2066" not in captured.out + captured.err
    assert "arm\\u202egpj.exe\\u2066" in captured.out




def test_info_finds_the_packages_of_a_model_in_the_folders_named_by_package_path(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    model = tmp_path / "vehicle.urdf.xacro"  # the fixture's vehicle, away from its workspace
    model.write_text((ROS_WORKSPACE / "fixture_vehicle_description" / "urdf" / "vehicle.urdf.xacro").read_text())
    assert main(["info", str(model)]) == 2
    err = one_line(capsys)
    assert "no ROS package 'fixture_arm_description'" in err and "--package-path DIR" in err and "Traceback" not in err
    assert main(["info", str(model), "--package-path", str(tmp_path), "--package-path", str(ROS_WORKSPACE)]) == 0
    captured = capsys.readouterr()
    assert "arm DOF 2" in captured.out and "shoulder" in captured.out and "elbow" in captured.out
    assert "mesh" not in captured.err  # the hull's package:// mesh is found too
    assert main(["info", str(model), "--package-path", str(tmp_path / "absent")]) == 2
    assert "does not exist; package_path names folders" in one_line(capsys)


def test_info_groups_the_joints_and_says_why(capsys):
    assert main(["info", str(ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf")]) == 0
    out = capsys.readouterr().out
    titles = [line.split(" (")[0] for line in out.splitlines() if re.match(r"[a-z].* \(\d+\): ", line)]
    assert titles == ["arm joints", "mimics", "propellers", "sensors", "fixed by range"]
    assert "arm joints (7): what a user commands" in out and "sensors (6): sensor mounts; frozen" in out
    assert re.search(r"\n  finger_c +follows 'finger_a' \(composed through finger_b\): q = -0.5 q\(finger_a\) \+ 0.1\n",
                     out)
    assert re.search(r"\n  anchor +limits \[0.2, 0.2\]: upper - lower <= 1e-09; held at 0.2\n", out)
    assert "ee rule     'arm_tool' (named like an end effector: 'tool' or '*_tool') on the arm of joint 'j1'" in out
    assert "arm DOF 7" in out


def test_info_columns_stay_aligned_with_long_joint_names(tmp_path, capsys):
    long = "a_joint_name_longer_than_the_24_character_column"
    path = tmp_path / "long.urdf"
    path.write_text(urdf(root=FLOATING_ROOT).replace('"j1"', f'"{long}"'))
    assert main(["info", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    start = lines.index("joints")
    header, rows = lines[start + 1], lines[start + 2: start + 4]
    assert [row.split()[0] for row in rows] == ["float", long]
    assert rows[0].index("FreeFlyer") == rows[1].index("RZ") == header.index("type")  # before: pushed right
    assert rows[0].rindex("-") == rows[1].index("[-1.0000") == header.index("limits")
    assert re.search(rf"\n  {long} revolute, limits \[-1, 1\]\n", "\n".join(lines) + "\n")


def test_info_lists_the_thrusters_and_the_hydrodynamics(capsys):
    assert main(["info", "bluerov2_alpha5"]) == 0
    out = capsys.readouterr().out
    # models/bluerov2_alpha5/thrusters.yaml: thruster_1 at (0.14, -0.092, 0) pushing along (-1, -1, 0)/sqrt(2)
    assert re.search(r"thrusters \(8\) from .*thrusters.yaml", out)
    assert "  thruster_1   xyz [+0.140 -0.092 +0.000]  dir [-0.707 -0.707 +0.000]  [-40.2, 51.5]  0.1\n" in out
    # the URDF's underwater-object plugin: base_link's volume and added-mass diagonal (FLU: a diagonal keeps signs)
    assert "hydrodynamics (7 links, rho 1028 kg/m^3)" in out
    assert "  base_link: V 0.01197  CoB [+0.000 +0.000 +0.010]" in out
    assert "    added mass [6.36 7.12 18.68 0.189 0.135 0.222]\n" in out
    assert (f"  from the uuv_simulator hydrodynamics plugin blocks of {ROOT}/models/bluerov2_alpha5/"
            "uvms.urdf.xacro\n") in out


def test_info_shows_a_hydrodynamics_yaml_with_where_it_comes_from(tmp_path, capsys):
    """An identified YAML (uvms identify writes it with two comment lines on top): its path, its notes and its
    values in place of the model's."""
    import dataclasses

    from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
    from uvms.dynamics.hydro.writer import hydrodynamics_yaml_text

    from conftest import shipped

    model = hydrodynamics_of(shipped("bluerov2_alpha5"))
    link = dataclasses.replace(model.links["base_link"], linear_damping=[13.8, 0.0, 33.13, 0.0014, 0.8, 0.0024])
    path = tmp_path / "hydrodynamics.yaml"
    path.write_text(hydrodynamics_yaml_text(dataclasses.replace(model, links={**model.links, "base_link": link}),
                                            ["identified by uvms identify from my_bag", "link base_link"]))
    assert main(["info", "bluerov2_alpha5", "--hydrodynamics", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"  from {path}\n  note: identified by uvms identify from my_bag\n  note: link base_link\n" in out
    # the file stores 0 as -0.0 of the SNAME convention (X_v = -0.0): shown as 0, not -0
    assert "    linear [13.8 0 33.13 0.0014 0.8 0.0024]  quadratic [141 217 190 1.19 0.47 1.5]\n" in out


def test_info_says_which_thruster_values_are_defaults(capsys):
    """uuv_simulator's plugins without thrustMin/thrustMax: the fixture's thruster_3 gives thrustMax 300 only."""
    assert main(["info", str(ROOT / "tests" / "fixtures" / "uuv" / "four_thrusters.urdf")]) == 0
    captured = capsys.readouterr()
    assert "  thruster_3   xyz [-0.400 +0.200 -0.100]  dir [-1.000 +0.000 +0.000]  [-2000, 300]  0.05\n" in captured.out
    assert "hydrodynamics none" in captured.out
    assert "uvms's default thruster values" in captured.err and "max_reverse = 2000 N for thruster_0" in captured.err


def test_info_says_which_wrench_directions_the_thrusters_cannot_produce(capsys):
    """Four thrusters give at most four of the six directions: info names the two missing (rank 4), and says that
    the BlueROV2 Heavy's eight give all six."""
    assert main(["info", str(ROOT / "tests" / "fixtures" / "uuv" / "four_thrusters.urdf")]) == 0
    line = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("allocation  "))
    assert line.startswith("allocation  the thrusters produce 4 of the 6 body-wrench directions; missing: a ")
    assert main(["info", "bluerov2_alpha5"]) == 0
    assert "allocation  every body-wrench direction (rank 6)\n" in capsys.readouterr().out


@pytest.mark.parametrize("content", [None, "links: [1, 2\n", "links:\n  nowhere_link: {volume: 1}\n"])
def test_info_with_a_hydrodynamics_file_it_cannot_use_exits_2_with_one_line(tmp_path, capsys, content):
    """The file the user named is the subject of the command: missing or invalid is an error, not a described line."""
    path = tmp_path / "hydrodynamics.yaml"
    if content is not None:
        path.write_text(content)
    assert main(["info", "bluerov2_alpha5", "--hydrodynamics", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.splitlines()) == 1
    assert captured.err.startswith("uvms: error: ") and "hydrodynamics" in captured.err


def test_a_hydrodynamic_block_naming_a_missing_link_is_skipped_or_refused_with_strict(tmp_path, capsys):
    """DAVE's RexROV idiom: an underwater-object block for 'oberon7/base', which the model does not have. uvms info
    skips it with a warning naming the link (as Gazebo skips it) and lists the other block; --strict refuses."""
    text = urdf(root=FLOATING_ROOT).replace("</robot>", """
  <gazebo><plugin name="uuv_plugin" filename="libuuv_underwater_object_ros_plugin.so">
    <fluid_density>1028.0</fluid_density>
    <link name="base_link"><volume>0.0195</volume><hydrodynamic_model><type>fossen</type>
      <linear_damping>-10 -20 -30 -1 -2 -3</linear_damping></hydrodynamic_model></link>
    <link name="oberon7/base"><volume>0.01</volume></link>
  </plugin></gazebo></robot>""")
    path = tmp_path / "rexrov_oberon.urdf"
    path.write_text(text)
    assert main(["info", str(path)]) == 0
    captured = capsys.readouterr()
    assert "hydrodynamics (1 links, rho 1028 kg/m^3)" in captured.out and "  base_link: V 0.0195" in captured.out
    assert ("uvms: warning: " + str(path) + ": hydrodynamics of link 'oberon7/base': the model has no link "
            "'oberon7/base'") in captured.err and "the block is skipped, as Gazebo skips it" in captured.err
    assert main(["info", str(path), "--strict"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("uvms: error: ") and "the model has no link 'oberon7/base'" in err
    assert "(--strict: a warning is an error)" in err and err.count("\n") == 1


def test_info_of_gazebo_sim_and_hippocampus_models(capsys):
    """The fixtures written as blue (use_sim:=true) and hippo_sim write their vehicles: thrusters and hydrodynamics
    read from their plugins, no arm joint."""
    folder = ROOT / "tests" / "fixtures" / "gz"
    assert main(["info", str(folder / "bluerov2_heavy_sim.urdf")]) == 0
    out = capsys.readouterr().out
    assert "arm DOF 0" in out and "propellers (8)" in out and "thrusters (8) from" in out
    assert "  thruster5_joint xyz [+0.118 -0.215 +0.064]  dir [+0.000 +0.000 -1.000]  [-40.2, 51.5]  0.1\n" in out
    assert "    linear [0 0 0 0 0 0]  quadratic [58.42 55.14 124.8 4 4 4]\n" in out
    assert main(["info", str(folder / "hippo" / "hippo_bluerov.urdf")]) == 0
    out = capsys.readouterr().out
    assert "  thruster_4   xyz [+0.120 -0.220 +0.060]  dir [+0.000 +0.000 +1.000]  [-43.0438, 43.0438]  0.05\n" in out
    assert "from the HippoCampus hydrodynamics, HippoCampus buoyancy plugin blocks of" in out
    assert "  bluerov/base_link: V 0.01071  CoB [+0.000 +0.000 +0.005]\n" in out


IDIOMS = ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf"


def test_arm_joints_on_info_view_and_workspace(tmp_path, monkeypatch, capsys):
    """``--arm-joints`` (repeatable or comma-separated, "" for none) on the three commands that load a model, as a
    scenario's [model] arm_joints: the other joints frozen and listed so (before: an unknown option, exit 2)."""
    assert main(["info", str(IDIOMS), "--arm-joints", "j1,j2", "--arm-joints", "j3"]) == 0
    out = capsys.readouterr().out
    assert "arm DOF 3 (nq 10, nv 9)" in out and "frozen (4): left out of arm_joints" in out
    assert re.search(r"j6 +not in arm_joints: held at 0.3", out)
    assert main(["info", str(IDIOMS), "--arm-joints", ""]) == 0
    assert "vehicle DOF 6, arm DOF 0 (nq 7, nv 6)" in capsys.readouterr().out  # the fins of an AUV, frozen
    assert main(["info", str(IDIOMS), "--arm-joints", "j1,nope"]) == 2
    assert "unknown arm joint 'nope'" in one_line(capsys)

    from uvms.viz import drawing

    drawn = []
    monkeypatch.setattr(drawing, "snapshot_figure", lambda robot, *args, **options: drawn.append(robot))
    assert main(["view", str(IDIOMS), "--arm-joints", "j1", "--headless", str(tmp_path / "j1.png")]) == 0
    assert drawn[-1].n_arm == 1 and [joint.name for joint in drawn[-1].arm_joints] == ["j1"]
    assert main(["view", "--result", str(tmp_path), "--arm-joints", "j1", "--headless", str(tmp_path / "r.png")]) == 2
    assert "drawn with the arm joints it was run with" in one_line(capsys)

    out = tmp_path / "workspace"
    assert main(["workspace", str(IDIOMS), "--arm-joints", "j1", "-n", "200", "--quiet", "--out", str(out)]) == 0
    import numpy as np

    with np.load(out / "points.npz") as points:
        assert points["q_arm_tool"].shape == (200, 1)  # one joint sampled


def test_info_says_when_a_continuous_joints_written_limits_are_ignored(tmp_path, capsys):
    """URDF gives a continuous joint no position limits (urdfdom, Pinocchio): right, and now said (the Girona 500's
    ARM5E writes them); a continuous joint writing only velocity and effort, and a revolute one, get no line."""
    second = ('<link name="l2"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>'
              '</inertial></link><joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/>'
              '<axis xyz="1 0 0"/><limit effort="1" velocity="2"/></joint>')
    path = tmp_path / "girona_like.urdf"
    path.write_text(urdf(root=FLOATING_ROOT, extra=second).replace('"revolute"', '"continuous"', 1))
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "arm DOF 2" in out
    assert [line for line in out.splitlines() if line.startswith("limits ")] == [
        "limits      j1: continuous, so its written limits [-1, 1] are ignored (a continuous joint turns without "
        "position limits; its velocity and effort limits are kept); make it revolute to keep them"]
    assert main(["info", "bluerov2_alpha5"]) == 0
    assert not [line for line in capsys.readouterr().out.splitlines() if line.startswith("limits ")]
