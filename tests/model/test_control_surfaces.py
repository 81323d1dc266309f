"""Which joints are fins (uvms.model.control_surfaces): a uuv_simulator fin plugin's joint (by <joint_name> or by its
link), a Gazebo Sim LiftDrag's control joint or the revolute joint that turns its link; not a rotor blade."""

from __future__ import annotations

import uvms

ROBOT = """<robot name="auv">
  <link name="world"/>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull"/></joint>
  <link name="hull"><inertial><mass value="10"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  </link>
  {joints}
  <gazebo>{plugins}</gazebo>
</robot>"""
JOINT = """<joint name="{name}" type="{kind}"><origin xyz="-0.5 0 0"/><axis xyz="0 0 1"/>
  <limit effort="0" lower="-0.3" upper="0.3" velocity="1"/><parent link="hull"/><child link="{name}_link"/></joint>
  <link name="{name}_link"><inertial><mass value="0.1"/>
  <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>"""
UUV = """<plugin name="{name}" filename="libuuv_fin_ros_plugin.so"><link_name>{link}</link_name>{joint}
  <dynamics><type>FirstOrder</type><timeConstant>0.1</timeConstant></dynamics>
  <liftdrag><type>Quadratic</type><lift_constant>1</lift_constant><drag_constant>1</drag_constant></liftdrag></plugin>"""
GZ = """<plugin filename="gz-sim-lift-drag-system" name="gz::sim::systems::LiftDrag"><link_name>{link}</link_name>
  {control}<air_density>1000</air_density></plugin>"""


def classes(tmp_path, joints, plugins):
    path = tmp_path / "auv.urdf"
    path.write_text(ROBOT.format(joints="".join(JOINT.format(name=n, kind=k) for n, k in joints),
                                 plugins="".join(plugins)))
    return uvms.load(path).joint_classes


def test_uuv_fin_plugins_name_their_joint_or_their_link(tmp_path):
    found = classes(tmp_path, [("a", "revolute"), ("b", "revolute"), ("c", "revolute")],
                    [UUV.format(name="fin_a", link="a_link", joint="<joint_name>a</joint_name>"),
                     UUV.format(name="fin_b", link="b_link", joint="")])
    assert found["a"].kind == found["b"].kind == "fin" and found["c"].kind == "arm"
    assert found["a"].reason == "uuv_simulator fin plugin 'fin_a' names it (<joint_name>); held at 0"
    assert found["b"].reason == ("its link 'b_link' is the <link_name> of uuv_simulator fin plugin 'fin_b'; held at 0")
    assert found["a"].limits == (-0.3, 0.3)


def test_gz_lift_drag_makes_a_fin_of_its_control_joint_or_its_link_joint_but_not_of_a_rotor(tmp_path):
    """A LiftDrag on a blade spun by a continuous joint (Gazebo's propeller demo) is no control surface."""
    found = classes(tmp_path, [("a", "revolute"), ("b", "revolute"), ("rotor", "continuous")],
                    [GZ.format(link="hull", control="<control_joint_name>a</control_joint_name>"),
                     GZ.format(link="b_link", control=""), GZ.format(link="rotor_link", control="")])
    assert found["a"].kind == found["b"].kind == "fin" and found["rotor"].kind == "arm"
    assert found["a"].reason.startswith("Gazebo Sim LiftDrag 'gz::sim::systems::LiftDrag' names it "
                                        "(<control_joint_name>)")
