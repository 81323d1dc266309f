"""Untrusted xacro runs in a restricted child process; trusted xacro and plain URDF load in-process."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_errors import urdf

import uvms
from uvms.sandbox import expand_untrusted

# Escapes xacro's name filter through python.vars(python.type) to reach io.FileIO, then writes a file.
ESCAPE = ("[f for b in python.vars(python.type)['__subclasses__'](python.type(()).mro()[1]) if 'io._IOBase' in "
          "python.repr(b) for r in python.vars(python.type)['__subclasses__'](b) if 'RawIOBase' in python.repr(r) "
          "for f in python.vars(python.type)['__subclasses__'](r) if 'FileIO' in python.repr(f)][0]"
          "('{target}', 'w').write(b'owned')")


def xacro_file(folder: Path, expression: str) -> Path:
    path = folder / "model.urdf.xacro"
    path.write_text(f"""<?xml version="1.0"?>
<robot name="evil" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="payload" value="${{{expression}}}"/>
  <link name="world"/>
  <link name="hull{'${payload}'}"><inertial><mass value="10"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull{'${payload}'}"/></joint>
</robot>
""")
    return path


def test_untrusted_xacro_cannot_write_a_file(tmp_path):
    target = tmp_path / "pwned.txt"
    path = xacro_file(tmp_path, ESCAPE.format(target=target))
    with pytest.raises(uvms.XacroError, match="may not write files"):
        uvms.load(path)  # a user file: untrusted by default
    assert not target.exists()
    robot = uvms.load(path, trusted=True)  # what the switch guards against: in-process, the write happens
    assert target.read_bytes() == b"owned" and robot.model.nq == 7


def test_untrusted_xacro_times_out(tmp_path):
    path = xacro_file(tmp_path, "python.sum(python.range(10**11))")
    with pytest.raises(uvms.XacroError, match="longer than 1 s"):
        expand_untrusted(path, {}, timeout=1.0)


def test_untrusted_xacro_gives_the_same_model_and_errors(tmp_path):
    shipped = uvms.resources.shipped_models()["xiang2019"]
    inside = uvms.load(shipped, args={"hull_height": 0.8})
    outside = uvms.load(shipped, args={"hull_height": 0.8}, trusted=False)
    assert outside.urdf == inside.urdf
    broken = tmp_path / "broken.urdf.xacro"
    broken.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="${undefined_x}"/></robot>')
    with pytest.raises(uvms.XacroError, match="undefined_x"):
        uvms.load(broken)
    malformed = tmp_path / "malformed.urdf.xacro"
    malformed.write_text("<robot name='r'><link name='a'></robot>")
    with pytest.raises(uvms.ModelParseError):
        uvms.load(malformed)


def test_plain_urdf_is_never_executed(tmp_path):
    path = tmp_path / "plain.urdf"
    path.write_text(urdf().replace('"l1"', '"l1${1+1}"'))  # no xacro: the text is a name, not code
    robot = uvms.load(path, ee="l1${1+1}")
    assert robot.ee_frames == ["l1${1+1}"]
