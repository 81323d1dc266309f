"""The files of a workspace run folder: frame names from a model never become folders."""

from __future__ import annotations

import json

from uvms.cli import main

INERTIA = 'ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"'
#: A vehicle whose frames are named as a ROS namespace writes them: ``rov/...``.
NAMESPACED = f"""<robot name="rov">
  <link name="world"/>
  <link name="rov/base_link"><inertial><mass value="10"/><inertia {INERTIA}/></inertial></link>
  <joint name="rov/base_joint" type="floating"><parent link="world"/><child link="rov/base_link"/></joint>
  <link name="rov/arm"><inertial><mass value="1"/><inertia {INERTIA}/></inertial></link>
  <joint name="rov/shoulder" type="revolute"><parent link="rov/base_link"/><child link="rov/arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="rov/end_effector"/>
  <joint name="rov/ee_joint" type="fixed"><parent link="rov/arm"/><child link="rov/end_effector"/>
    <origin xyz="0.5 0 0"/></joint>
</robot>
"""


def test_a_frame_named_with_a_slash_gives_one_file_in_the_run_folder(tmp_path):
    model = tmp_path / "rov.urdf"
    model.write_text(NAMESPACED)
    out = tmp_path / "out"
    assert main(["workspace", str(model), "--ee", "rov/end_effector", "-n", "2000", "--dexterity", "--roll-bins", "1",
                 "--directions", "20", "--out", str(out), "--quiet"]) == 0
    figures = json.loads((out / "metrics.json").read_text())["figures"]
    assert "dexterity_rov_end_effector.png" in figures and (out / "dexterity_rov_end_effector.png").is_file()
    assert not any(path.is_dir() for path in out.iterdir())
