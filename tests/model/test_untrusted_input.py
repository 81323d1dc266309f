"""Untrusted input to the loader (uvms.model.loader, uvms.model.checks): xacro args from outside are data at
every entry point; models no UVMS has are refused early."""

from __future__ import annotations

import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.cli import main
from uvms.model import loader as model

from conftest import ESCAPE, FLOATING_ROOT, ROOT, urdf


def payload(target: Path) -> str:
    """Arg text that writes ``target`` when pasted into a ``${...}`` expression of a shipped model."""
    return "(" + ESCAPE.format(target=target) + ")"


def test_the_payload_is_real_code_when_the_check_is_bypassed(tmp_path, monkeypatch):
    # control: without the data rule, amundsen2018's ${$(arg diameter) / 2.0} runs the payload in-process
    target = tmp_path / "owned.txt"
    monkeypatch.setattr(model, "format_xacro_value", lambda name, value, path="": str(value))
    uvms.load("amundsen2018", args={"diameter": payload(target)})  # write() returns 5: a 5 m diameter
    assert target.read_bytes() == b"owned"


def test_code_in_args_is_refused_through_the_api(tmp_path):
    target = tmp_path / "owned.txt"
    for bad in (payload(target), "1+1 if True else 0", "a b", "'quoted'", "x__class__", "$(find pkg)", "${1}",
                "a" * 300, float("nan"), float("inf"), [1, 2], {"a": 1}, None):
        with pytest.raises(uvms.errors.XacroError, match="diameter=.*(not allowed|not finite)"):
            uvms.load("amundsen2018", args={"diameter": bad})
    with pytest.raises(uvms.errors.XacroError, match="arg name"):
        uvms.load("amundsen2018", args={"diameter) + (1": 0.2})
    assert not target.exists()


def test_data_args_still_work():
    base = uvms.load("amundsen2018")
    for value in (0.25, "0.25", 1, True and 0.25, "2.5e-1", np.float64(0.25)):
        robot = uvms.load("amundsen2018", args={"diameter": value})
        assert robot.model.nq == base.model.nq
    longer, default = uvms.load("hoang2011", args={"l1": "0.6"}), uvms.load("hoang2011")
    reach = [np.linalg.norm(r.fk(r.configuration(base=[0, 0, 0], arm=[0, 0, 0]), "ee").translation - r.fk(
        r.configuration(base=[0, 0, 0], arm=[0, 0, 0]), "link1").translation) for r in (longer, default)]
    assert reach[0] == pytest.approx(reach[1] + 0.2, abs=1e-12)
    assert model.format_xacro_value("flag", False) == "false"
    assert model.format_xacro_value("mesh", "meshes/hull-v2.stl") == "meshes/hull-v2.stl"


def cli_line(capsys, argv) -> tuple[int, str]:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    return code, err


def test_code_in_args_is_refused_through_every_cli_entry_point(tmp_path, capsys):
    target = tmp_path / "owned.txt"
    code = payload(target)
    toml = "'''" + code + "'''"  # a TOML literal string: the payload holds single quotes
    scenario = tmp_path / "evil.toml"
    scenario.write_text((ROOT / "scenarios" / "amundsen2018_rigid_open_loop.toml").read_text()
                        .replace('path = "../models/amundsen2018/usm.urdf.xacro"',
                                 f'path = "amundsen2018"\nargs = {{ diameter = {toml} }}'))
    assert "diameter" in scenario.read_text()
    runs = [
        ["info", "amundsen2018", "--arg", f"diameter={code}"],
        ["run", str(scenario), "--out", str(tmp_path / "a"), "--quiet"],
        ["run", str(ROOT / "scenarios" / "amundsen2018_rigid_open_loop.toml"), "--out", str(tmp_path / "b"),
         "--quiet", "--set", f"model.args.diameter={toml}"],
        ["sweep", str(ROOT / "scenarios" / "amundsen2018_rigid_open_loop.toml"), "--out", str(tmp_path / "c"),
         "--quiet", "--grid", f"model.args.diameter=[{toml}]"],
        ["workspace", "amundsen2018", "--arg", f"diameter={code}", "--ee", "ee", "-n", "10",
         "--out", str(tmp_path / "d")],
    ]
    for argv in runs:
        status, err = cli_line(capsys, argv)
        assert status == 2, argv[0]
        assert "diameter" in err and "not allowed" in err, (argv[0], err)
        assert len(err.splitlines()) == 1, err
    assert not target.exists()


def chain_urdf(links: int, joint_type: str = "revolute") -> str:
    body = '<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
    parts = [f'<link name="l{i}">{body if i else ""}</link>' for i in range(links)]  # l0: a massless mount, fixed
    parts += [f'<joint name="j{i}" type="{joint_type}"><parent link="l{i}"/><child link="l{i + 1}"/>'
              f'<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
              "</joint>" for i in range(links - 1)]
    return f'<robot name="chain">{"".join(parts)}</robot>'


def peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def test_models_no_uvms_has_are_refused_before_pinocchio():
    started, rss = time.perf_counter(), peak_rss_mib()
    with pytest.raises(uvms.errors.ModelCheckError, match="10000 links; at most 1000"):
        uvms.load(chain_urdf(10_000, "fixed"))  # Pinocchio's parser segfaults on this chain
    with pytest.raises(uvms.errors.ModelCheckError, match="400 degrees of freedom; at most 100"):
        uvms.load(chain_urdf(401))  # Pinocchio's createData would take 4.5 GiB
    with pytest.raises(uvms.errors.ModelCheckError, match="MiB of text"):
        uvms.load('<robot name="big"><link name="a"/>' + "<!--" + "x" * (33 << 20) + "--></robot>")
    assert time.perf_counter() - started < 20 and peak_rss_mib() - rss < 500
    assert uvms.load(chain_urdf(95)).nv == 94  # a long arm is fine


@pytest.mark.parametrize("text, match", [
    (urdf(xyz="1e308 0 0"), "exceeds 1e\\+09"),
    (urdf(mass="1e308"), "exceeds 1e\\+09"),
    (urdf(ixx="1e300"), "exceeds 1e\\+09"),
    (urdf().replace('lower="-1" upper="1"', 'lower="1" upper="-1"'), "lower = 1 > upper = -1"),
    (urdf().replace('lower="-1"', 'lower="-1e300"'), "exceeds 1e\\+20"),
    (urdf(extra='<link name="l1"/>'), "two links are named 'l1'"),
    (urdf(extra='<link name="l2"/><joint name="j1" type="fixed"><parent link="l1"/><child link="l2"/></joint>'),
     "two joints are named 'j1'"),
    (urdf().replace('type="revolute"', 'type="revolutee"'), "type 'revolutee'; valid"),
])
def test_overflowing_and_contradictory_models_are_refused(text, match):
    with pytest.raises(uvms.errors.ModelCheckError, match=match):
        uvms.load(text)


def test_unbounded_limit_idiom_still_loads():
    assert uvms.load(urdf().replace('lower="-1" upper="1"', 'lower="-1e16" upper="1e16"')).nq == 1


def test_duplicate_names_give_one_line_and_nothing_on_stderr(tmp_path):
    path = tmp_path / "dup.urdf"
    path.write_text(urdf(extra='<link name="l1"/>'))
    done = subprocess.run([sys.executable, "-m", "uvms.cli", "info", str(path)], capture_output=True, text=True)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "two links are named 'l1'" in done.stderr


def test_mimic_joints_follow_their_leader():
    text = urdf(extra="""<link name="l2"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0"
        iyz="0"/></inertial></link><joint name="j2" type="revolute"><parent link="base_link"/><child link="l2"/>
        <origin xyz="0 1 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
        <mimic joint="j1" multiplier="-2" offset="0.1"/></joint>""")
    robot = uvms.load(text, ee="l2")
    assert robot.nq == 1  # j2 adds no degree of freedom
    q = np.array([0.3])
    expected = -2 * 0.3 + 0.1
    rotation = robot.fk(q, "l2").rotation
    assert np.arctan2(rotation[1, 0], rotation[0, 0]) == pytest.approx(expected, abs=1e-12)


def test_massless_floating_model_gives_a_model_error_not_linalg():
    massless = urdf(root=FLOATING_ROOT, mass="0", ixx="0").replace('iyy="1" izz="1"', 'iyy="0" izz="0"')
    robot = uvms.load(massless)
    q = robot.configuration(base=[0, 0, 0, 0, 0, 0], arm=[0.1])
    assert robot.jacobian(q).shape == (6, 7)  # kinematics needs no mass
    with pytest.raises(uvms.errors.ModelCheckError, match="massless"):
        robot.generalized_jacobian(q)
    with pytest.raises(uvms.errors.ModelCheckError, match="massless"):
        robot.base_velocity(q, arm_velocity=np.ones(1))


def test_symlink_loop_and_self_include_give_one_line(tmp_path):
    (tmp_path / "a.urdf").symlink_to(tmp_path / "b.urdf")
    (tmp_path / "b.urdf").symlink_to(tmp_path / "a.urdf")
    with pytest.raises(uvms.errors.ModelFileNotFound, match="symbolic link that leads nowhere"):
        uvms.load(tmp_path / "a.urdf")
    looped = tmp_path / "self.urdf.xacro"
    looped.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                      '<xacro:include filename="self.urdf.xacro"/><link name="a"/></robot>')
    for trusted in (True, False):
        with pytest.raises(uvms.errors.XacroError, match="recursion too deep"):
            uvms.load(looped, trusted=trusted)
