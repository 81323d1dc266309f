"""HippoCampus's hippo_gz_plugins read as model data (uvms.dynamics.plugins.hippo), checked against the plugins' own
equations (thruster_private.cpp ThrusterForce, hydrodynamics.cpp UpdateForcesAndMoments, buoyancy_private.cpp
ApplyBuoyancy), and hippo_sim's BlueROV (tests/fixtures/gz/hippo/hippo_bluerov.urdf) loading and holding station."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import uvms
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of, parse_hydrodynamics
from uvms.dynamics.plugins.readers import lumped_mass, read_thruster_plugins
from uvms.dynamics.thrusters.thrusters import placements_in_base, thrusters_of
from uvms.errors import ModelCheckError
from uvms.scenario import run_scenario

from conftest import ROOT

FIXTURES = ROOT / "tests" / "fixtures" / "gz" / "hippo"
T200 = ("<maximum_rpm>3240</maximum_rpm><quadratic_coeff>0.015547</quadratic_coeff><linear_coeff>-0.04243"
        "</linear_coeff><constant_coeff>0.0</constant_coeff>")


def thruster_force(rotor_velocity: float, a: float, b: float, c: float, propeller_direction: int = 1) -> float:
    """thruster_private.cpp ThrusterForce: n = |omega / 6.28|, T = a n^2 + b n + c clipped at 0, signed by omega."""
    n = abs(rotor_velocity / 6.28)
    thrust = max(0.0, n * n * a + n * b + c)
    return propeller_direction * (-thrust if rotor_velocity < 0 else thrust)


def read(body: str):
    root = ET.fromstring('<robot name="r"><link name="b"/><link name="p"/><joint name="j" type="continuous"><parent '
                         'link="b"/><child link="p"/><axis xyz="1 0 0"/></joint><gazebo><plugin filename="thruster" '
                         f'name="hippo_gz_plugins::thruster"><link>p</link><joint>j</joint>{body}</plugin></gazebo>'
                         '</robot>')
    (found,) = read_thruster_plugins(root, "m")
    return found


def test_the_thrust_limit_is_the_curve_at_full_throttle():
    """Full throttle: omega = 1 * turning_direction * 3240 / 60 * 3.14 * 2 (ThrottleToVelocity); the thrust there is
    the largest, 43.04 N for the T200 curve, and the same backwards."""
    found = read(T200)
    omega = 3240 / 60.0 * 3.14 * 2
    expected = thruster_force(omega, 0.015547, -0.04243, 0.0)
    assert expected == pytest.approx(43.0438, abs=1e-4)
    assert found.given["max_forward"] == pytest.approx(expected, rel=1e-12)
    assert found.given["max_reverse"] == pytest.approx(-thruster_force(-omega, 0.015547, -0.04243, 0.0), rel=1e-12)
    assert found.direction is None and found.link == "p" and found.name == "thruster_0"  # along the link's x axis
    assert "time_constant" not in found.given  # the T200's 0.00 s: no lag the plugin gives
    assert read(T200 + "<timeconstant_up>0.04</timeconstant_up><timeconstant_down>0.04</timeconstant_down>"
                ).given["time_constant"] == 0.04
    assert "time_constant" not in read(T200 + "<timeconstant_up>0.04</timeconstant_up>").given


def test_a_curve_that_falls_again_takes_its_top():
    """a < 0: the thrust peaks inside [0, n_max] at n = -b / 2a (here 20 rev/s: 40 N), not at full throttle."""
    found = read("<maximum_rpm>1800</maximum_rpm><quadratic_coeff>-0.1</quadratic_coeff><linear_coeff>4"
                 "</linear_coeff>")
    assert found.given == {"max_forward": pytest.approx(40.0), "max_reverse": pytest.approx(40.0)}
    with pytest.raises(ModelCheckError, match="<link> is missing"):
        read_thruster_plugins(ET.fromstring('<robot name="r"><link name="b"/><gazebo><plugin filename="thruster" '
                                            'name="hippo_gz_plugins::thruster"/></gazebo></robot>'), "m")
    with pytest.raises(ModelCheckError, match="its largest thrust is 0 N"):
        read("<maximum_rpm>0</maximum_rpm>")


HYDRO = ('<plugin filename="hydrodynamics" name="hippo_gz_plugins::hydrodynamics"><hydrodynamics><link>body</link>'
         '<added_mass_linear>1.11 2.8 2.8</added_mass_linear><added_mass_angular>0.00451 0.0163 0.0163'
         '</added_mass_angular><damping_linear>5.39 17.36 17.36</damping_linear><damping_angular>0.00174 0.007 0.007'
         '</damping_angular></hydrodynamics></plugin>')
BUOYANCY = ('<plugin filename="buoyancy" name="hippo_gz_plugins::buoyancy"><buoyancy><link_name>body</link_name>'
            '<origin>0.01 0 0.02</origin><force_added>0</force_added><compensation>1.02</compensation>'
            '<height_scale_limit>0.1</height_scale_limit></buoyancy></plugin>')


def body_urdf(plugins: str) -> str:
    return ('<robot name="r"><link name="body"><inertial><mass value="1.47"/><inertia ixx="1" ixy="0" ixz="0" '
            'iyy="1" iyz="0" izz="1"/></inertial></link><link name="cam"><inertial><mass value="0.03"/><inertia '
            'ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial></link><joint name="cam_joint" '
            f'type="fixed"><parent link="body"/><child link="cam"/></joint><gazebo>{plugins}</gazebo></robot>')


def test_damping_and_buoyancy_are_the_plugins_forces():
    """hippo3's numbers: the damping wrench is the plugin's -diag(damping) v; buoyancy rho g V is the plugin's
    9.81 m c with m the link's mass after Gazebo lumps its fixed child (1.47 + 0.03 kg), at <origin>."""
    hydro = parse_hydrodynamics(body_urdf(HYDRO + BUOYANCY), "hippo3.urdf")
    link = hydro.links["body"]
    velocity = np.array([0.4, -0.2, 0.1, 0.3, -0.5, 0.2])
    damping = np.concatenate([-np.array([5.39, 17.36, 17.36]) * velocity[:3],
                              -np.array([0.00174, 0.007, 0.007]) * velocity[3:]])
    np.testing.assert_allclose(link.damping_wrench(velocity), damping, rtol=1e-12)
    np.testing.assert_allclose(np.diag(link.added_mass), [1.11, 2.8, 2.8, 0.00451, 0.0163, 0.0163])
    assert hydro.fluid_density * hydro.gravity * link.volume == pytest.approx(9.81 * 1.5 * 1.02, rel=1e-12)
    np.testing.assert_allclose(link.center_of_buoyancy, [0.01, 0.0, 0.02])
    assert lumped_mass(ET.fromstring(body_urdf("")), "body") == pytest.approx(1.5)
    with pytest.raises(ModelCheckError, match="a non-zero <force_added>"):
        parse_hydrodynamics(body_urdf(BUOYANCY.replace("<force_added>0<", "<force_added>2<")))
    with pytest.raises(ModelCheckError, match="<damping_linear> must be >= 0"):
        parse_hydrodynamics(body_urdf(HYDRO.replace("5.39 17.36", "-5.39 17.36")))
    with pytest.raises(ModelCheckError, match="the link's volume is given twice"):
        parse_hydrodynamics(body_urdf(HYDRO + BUOYANCY + BUOYANCY))


@pytest.fixture(scope="module")
def hippo() -> uvms.Robot:
    with pytest.warns(uvms.errors.BaseGuessWarning):
        return uvms.load(FIXTURES / "hippo_bluerov.urdf")


def test_hippos_bluerov_has_eight_thrusters_on_their_links_x_axes(hippo):
    assert hippo.n_arm == 0 and len(hippo.joint_classes) == 8
    assert {joint_class.kind for joint_class in hippo.joint_classes.values()} == {"propeller"}
    thrusters = thrusters_of(hippo)
    assert thrusters.names == [f"thruster_{i}" for i in range(8)]
    _, directions = placements_in_base(hippo, thrusters)
    s = np.sqrt(0.5)
    np.testing.assert_allclose(directions[:4], [[s, s, 0], [s, -s, 0], [-s, s, 0], [-s, -s, 0]], atol=1e-12)
    np.testing.assert_allclose(directions[4:], [[0, 0, 1]] * 4, atol=1e-12)  # pitched -90 deg: x points up
    assert thrusters.upper == pytest.approx([43.0438] * 8, abs=1e-4) and thrusters.time_constants.tolist() == [0.05] * 8
    hydro = hydrodynamics_of(hippo)
    link = hydro.links["bluerov/base_link"]
    assert link.volume == pytest.approx(1.001 * 11.0 / hydro.fluid_density, rel=1e-12)
    np.testing.assert_allclose(link.linear_damping, [7, 7, 7, 0.3, 0.3, 0.3])


def test_hippos_bluerov_holds_station_with_weight_and_buoyancy(tmp_path):
    with pytest.warns(uvms.errors.BaseGuessWarning):
        run = run_scenario(FIXTURES / "hippo_station.toml", out=tmp_path / "out", progress=False)
    assert run.metrics["verdict"]["ok"] and 1e-4 < run.metrics["vehicle_position_error"] < 0.02
    assert run.metrics["saturated_time_fraction"] == 0.0
