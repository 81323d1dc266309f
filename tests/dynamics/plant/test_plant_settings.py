"""The plant's own settings (uvms.dynamics.plant.settings) and Plant.from_settings: each refusal begins with its
field; the plant they describe."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.plant.settings import PlantSettings
from uvms.errors import UVMSError

from conftest import body_urdf

BARE = """<robot name="bare">
  <link name="world"/>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull"/></joint>
  <link name="hull"><inertial><mass value="10"/>
    <inertia ixx="0.3" iyy="0.4" izz="0.5" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>"""


@pytest.mark.parametrize(("values", "words"), [
    ({"type": "kinematic"}, "type must be one of rigid, hydrodynamic"),
    ({"motor_time_constant": 0.0}, r"motor_time_constant must be > 0 s"),
    ({"motor_time_constant": float("nan")}, r"motor_time_constant must be > 0 s"),
    ({"current": (0.1, 0.0)}, "current must have 3 numbers"),
    ({"type": "rigid", "gravity": True}, "gravity needs type = 'hydrodynamic'"),
    ({"type": "rigid", "added_mass": True}, "added_mass needs type = 'hydrodynamic'"),
    ({"type": "rigid", "hydrodynamics": "mine.yaml"}, "hydrodynamics needs type = 'hydrodynamic'"),
])
def test_settings_refuse_what_no_plant_is_with_the_field_first(values, words):
    with pytest.raises(UVMSError, match=f"^{words}"):
        PlantSettings(**values)


def test_a_rigid_plant_floats_in_vacuum_and_a_hydrodynamic_one_has_the_models_fluid():
    robot = uvms.load(body_urdf())
    rigid = Plant.from_settings(robot, PlantSettings(type="rigid", motor_time_constant=0.2))
    assert not rigid.links and not rigid.gravity and not rigid.added_mass and not rigid.damping
    assert rigid.motor_time_constant == 0.2 and rigid.hydro.source == "rigid plant (no fluid)"
    fluid = Plant.from_settings(robot, PlantSettings(current=(0.3, -0.1, 0.0), gravity=True, damping=False))
    assert [link.name for link in fluid.links] == ["hull"]
    assert fluid.gravity and fluid.added_mass and not fluid.damping  # added_mass None: on
    np.testing.assert_allclose(fluid.current, [0.3, -0.1, 0.0], atol=1e-15)
    assert fluid.buoyant


def test_from_settings_refuses_a_fixed_base_a_model_without_fluid_and_a_bad_file(tmp_path):
    with pytest.raises(UVMSError, match="^type = 'rigid' needs a floating or planar vehicle; ur5 has a fixed base"):
        Plant.from_settings(uvms.load(uvms.model.example_robot_urdf("ur5")), PlantSettings(type="rigid"))
    with pytest.raises(UVMSError, match="^type = 'hydrodynamic' needs hydrodynamic parameters"):
        Plant.from_settings(uvms.load(BARE), PlantSettings())
    bad = tmp_path / "bad.yaml"
    bad.write_text("links:\n  no_such_link:\n    volume: 0.01\n")
    with pytest.raises(UVMSError, match="^hydrodynamics: .*no_such_link"):
        Plant.from_settings(uvms.load(body_urdf()), PlantSettings(hydrodynamics=str(bad)))
