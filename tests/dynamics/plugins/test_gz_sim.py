"""Gazebo Sim's Thruster, Hydrodynamics and Buoyancy systems read as model data (uvms.dynamics.plugins.gz_sim), checked
against gz-sim's own equations (Thruster.cc AngularVelToThrust, Hydrodynamics.cc and HydrodynamicsUtils.hh
buildDampingMatrix / buildCoriolisMatrix, rewritten below in numpy), and the blue package's BlueROV2 Heavy written with
use_sim:=true (tests/fixtures/gz/bluerov2_heavy_sim.urdf) loading and holding station."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.cli.info import describe
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of, parse_hydrodynamics
from uvms.dynamics.plugins.gz_sim import gz_buoyancy_density
from uvms.dynamics.plugins.readers import read_thruster_plugins
from uvms.dynamics.thrusters.thrusters import placements_in_base, thrusters_of
from uvms.errors import ModelCheckError, PluginSettingWarning
from uvms.scenario import run_scenario

from conftest import ROOT

FIXTURES = ROOT / "tests" / "fixtures" / "gz"


def fossen_coriolis(added_mass: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Fossen's C_A(nu) nu = [w x a1; v x a1 + w x a2], a = M_A nu (2011, eq. 6.43): what the plant applies."""
    a = added_mass @ nu
    return np.concatenate([np.cross(nu[3:], a[:3]), np.cross(nu[:3], a[:3]) + np.cross(nu[3:], a[3:])])
AXES, VELOCITIES = "xyzkmn", "UVWPQR"


def robot(plugins: str, axis: str = "0 0 -1", rpy: str = "0 1.2 0.3") -> ET.Element:
    return ET.fromstring(
        f'<robot name="r"><link name="b"/><link name="p"/><joint name="j" type="continuous"><origin rpy="{rpy}" '
        f'xyz="0.1 0.2 0.3"/><parent link="b"/><child link="p"/><axis xyz="{axis}"/></joint>'
        f'<gazebo>{plugins}</gazebo></robot>')


def thruster(body: str, filename: str = "gz-sim-thruster-system", name: str = "gz::sim::systems::Thruster"):
    (found,) = read_thruster_plugins(robot(f'<plugin filename="{filename}" name="{name}"><joint_name>j</joint_name>'
                                           f'{body}</plugin>'), "m")
    return found


@pytest.mark.parametrize("filename, name", [
    ("gz-sim-thruster-system", "gz::sim::systems::Thruster"), ("libgz-sim8-thruster-system.so", "anything"),
    ("ignition-gazebo-thruster-system", "x"), ("libignition-gazebo6-thruster-system.so", "x"),
    ("custom", "ignition::gazebo::systems::Thruster"), ("custom", "gz::sim::systems::Thruster")])
def test_every_name_of_the_thruster_system_is_read_with_the_joint_axis_in_the_child_link(filename, name):
    found = thruster("<max_thrust_cmd>50</max_thrust_cmd><min_thrust_cmd>-40</min_thrust_cmd>", filename, name)
    assert (found.name, found.link) == ("j", "p")  # named by its joint: gz plugins share a class name
    np.testing.assert_allclose(found.direction, [0.0, 0.0, -1.0])  # the axis, in the child link (= joint) frame
    assert found.given == {"max_forward": 50.0, "max_reverse": 40.0}


def gz_thrust(ct: float, rho: float, d: float, omega: float) -> float:
    """Thruster.cc, AngularVelToThrust: thrustCoefficient * D^4 * |omega| * omega * fluidDensity."""
    return ct * d ** 4 * abs(omega) * omega * rho


@pytest.mark.parametrize("body, expected", [
    ("", {}),  # blue's form: thrust commands, no limit given (gz's internal +-1000 N is no vehicle's limit)
    ("<max_thrust_cmd>60</max_thrust_cmd>", {"max_forward": 60.0}),
    # speed commands [rad/s]: the limits are the thrusts of the propeller law at the ends of the speed range
    ("<use_angvel_cmd>true</use_angvel_cmd><thrust_coefficient>0.02</thrust_coefficient><fluid_density>1000"
     "</fluid_density><propeller_diameter>0.1</propeller_diameter><max_thrust_cmd>300</max_thrust_cmd>"
     "<min_thrust_cmd>-250</min_thrust_cmd>",
     {"max_forward": gz_thrust(0.02, 1000, 0.1, 300), "max_reverse": -gz_thrust(0.02, 1000, 0.1, -250)}),
    # a clockwise propeller (negative coefficient): the highest speed gives the lowest thrust
    ("<use_angvel_cmd>1</use_angvel_cmd><thrust_coefficient>-0.02</thrust_coefficient><propeller_diameter>0.1"
     "</propeller_diameter><max_thrust_cmd>300</max_thrust_cmd><min_thrust_cmd>-250</min_thrust_cmd>",
     {"max_forward": gz_thrust(-0.02, 1000, 0.1, -250), "max_reverse": -gz_thrust(-0.02, 1000, 0.1, 300)}),
    # gz's defaults: coefficient 1, density 1000, diameter 0.02 m
    ("<use_angvel_cmd>True</use_angvel_cmd><thrust_coefficient>1</thrust_coefficient><max_thrust_cmd>100"
     "</max_thrust_cmd>", {"max_forward": gz_thrust(1.0, 1000, 0.02, 100)}),
    # no coefficient: gz computes it from alpha_1, alpha_2 and the speed: no limit uvms can take
    ("<use_angvel_cmd>true</use_angvel_cmd><max_thrust_cmd>300</max_thrust_cmd>", {}),
])
def test_the_limits_are_the_command_clamp_in_newtons_or_through_the_propeller_law(body, expected):
    given = thruster(body).given
    assert given.keys() == expected.keys()
    for key, value in expected.items():
        assert given[key] == pytest.approx(value, rel=1e-12)
    assert expected.get("max_forward") != 60.0 or gz_thrust(0.02, 1000, 0.1, 300) == pytest.approx(180.0)


@pytest.mark.parametrize("plugin, message", [
    ('<plugin filename="gz-sim-thruster-system" name="t"/>', "<joint_name> is missing"),
    ('<plugin filename="gz-sim-thruster-system" name="t"><joint_name>k</joint_name></plugin>',
     "unknown joint 'k'; valid joints: j"),
    ('<plugin filename="gz-sim-thruster-system" name="t"><joint_name>j</joint_name><use_angvel_cmd>yes'
     '</use_angvel_cmd></plugin>', "<use_angvel_cmd> must be true or false"),
    ('<plugin filename="gz-sim-thruster-system" name="t"><joint_name>j</joint_name><max_thrust_cmd>-5'
     '</max_thrust_cmd><min_thrust_cmd>0</min_thrust_cmd></plugin>', r"<max_thrust_cmd> \(-5\) must be >= "),
    ('<plugin filename="gz-sim-thruster-system" name="t"><joint_name>j</joint_name><max_thrust_cmd>-5'
     '</max_thrust_cmd></plugin>', "its largest thrust is -5 N; a thruster must push forward"),
])
def test_bad_thruster_plugins_are_refused_naming_them(plugin, message):
    with pytest.raises(ModelCheckError, match=message) as error:
        read_thruster_plugins(robot(plugin), "m")
    assert str(error.value).startswith("m: Gazebo Sim thruster plugin")


# ------------------------------------------------------------------ Hydrodynamics against gz's force
MA = np.array([[-5.0, 0.3, 0.0, 0.0, 0.1, 0.0], [0.3, -12.0, 0.0, 0.2, 0.0, 0.4], [0.0, 0.0, -20.0, 0.0, 0.5, 0.0],
               [0.0, 0.2, 0.0, -1.0, 0.0, 0.0], [0.1, 0.0, 0.5, 0.0, -2.0, 0.0], [0.0, 0.4, 0.0, 0.0, 0.0, -1.5]])
LINEAR = np.array([-3.0, -4.0, -6.0, -0.5, -0.7, -0.9])
QUADRATIC = np.array([-58.42, -55.137, -124.818, -4.0, -4.5, -5.0])


def hydro_plugin(extra: str = "", link: str = "body") -> str:
    tags = [f"<{a}Dot{v}>{float(MA[i, j])!r}</{a}Dot{v}>" for i, a in enumerate(AXES) for j, v in enumerate(VELOCITIES)
            if MA[i, j] != 0]
    tags += [f"<{a}{v}>{float(LINEAR[i])!r}</{a}{v}><{a}{v}abs{v}>{float(QUADRATIC[i])!r}</{a}{v}abs{v}>"
             for i, (a, v) in enumerate(zip(AXES, VELOCITIES))]
    return (f'<plugin filename="gz-sim-hydrodynamics-system" name="gz::sim::systems::Hydrodynamics"><link_name>{link}'
            f'</link_name>{"".join(tags)}{extra}</plugin>')


def body_urdf(plugins: str) -> str:
    return (f'<robot name="r"><link name="body"><inertial><mass value="30"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" '
            f'iyz="0" izz="1"/></inertial></link><gazebo>{plugins}</gazebo></robot>')


def gz_damping_force(state: np.ndarray) -> np.ndarray:
    """Hydrodynamics.cc: kDvec = buildDampingMatrix(...) * state, applied as -kDvec; buildDampingMatrix's
    D(i,j) = -linear[i*6+j] - sum_k quadAbs[i*36+j*6+k] |state(k)| (diagonal tags only here)."""
    linear, absolute = np.diag(LINEAR), np.zeros((6, 6, 6))
    for i in range(6):
        absolute[i, i, i] = QUADRATIC[i]
    damping = -linear - np.einsum("ijk,k->ij", absolute, np.abs(state))
    return -(damping @ state)


def gz_coriolis_matrix(ma: np.ndarray, s: np.ndarray) -> np.ndarray:
    """HydrodynamicsUtils.hh buildCoriolisMatrix(Ma, state): (row, column, sign, Ma index, state index) per entry."""
    entries = [(0, 4, -1, 2, 2), (0, 5, 1, 1, 1), (1, 3, 1, 2, 2), (1, 5, -1, 0, 0), (2, 3, -1, 1, 1), (2, 4, 1, 0, 0),
               (3, 1, -1, 2, 2), (3, 2, 1, 1, 1), (3, 4, -1, 5, 5), (3, 5, 1, 4, 4), (4, 0, 1, 2, 2), (4, 2, -1, 0, 0),
               (4, 3, 1, 5, 5), (4, 5, -1, 3, 3), (5, 0, -1, 1, 1), (5, 1, 1, 0, 0), (5, 3, -1, 4, 4), (5, 4, 1, 3, 3)]
    matrix = np.zeros((6, 6))
    for row, column, sign, index, velocity in entries:
        matrix[row, column] = sign * ma[index, index] * s[velocity]
    return matrix


def test_the_wrench_uvms_applies_is_gazebos_damping_and_added_mass_force():
    """Damping: uvms's -(D_l + D_q |nu|) nu is gz's -D(nu) nu to rounding; added mass: uvms's -M_A nu' is gz's
    applied -(-Ma nu') = Ma nu' (M_A = -Ma, off-diagonal <xDotV> ... included); the current is <default_current>;
    the Coriolis term is Fossen's -C_A(nu) nu (eq. 6.43 with the full M_A), which for a diagonal Ma is minus gz's
    buildCoriolisMatrix(Ma, nu) nu (gz adds it with the opposite sign: uvms keeps Fossen's, under which the added
    mass does no work)."""
    hydro = parse_hydrodynamics(body_urdf(hydro_plugin("<default_current>0.2 -0.1 0</default_current>")), "gz.urdf")
    link = hydro.links["body"]
    np.testing.assert_allclose(link.added_mass, -MA, atol=1e-12)
    np.testing.assert_allclose(hydro.current, [0.2, -0.1, 0.0])
    rng = np.random.default_rng(4)
    for _ in range(5):
        state, rate = rng.normal(size=6), rng.normal(size=6)
        np.testing.assert_allclose(link.damping_wrench(state), gz_damping_force(state), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(-link.added_mass @ rate, MA @ rate, rtol=1e-12, atol=1e-12)
        diagonal = np.diag(np.diag(MA))
        coriolis = gz_coriolis_matrix(diagonal, state)
        np.testing.assert_allclose(-fossen_coriolis(-diagonal, state), -coriolis @ state, atol=1e-12)


def test_disable_added_mass_drops_it_and_disable_coriolis_is_stated():
    hydro = parse_hydrodynamics(body_urdf(hydro_plugin("<disable_added_mass>true</disable_added_mass>")))
    assert not hydro.links["body"].added_mass.any()
    with pytest.warns(PluginSettingWarning, match="<disable_coriolis> is not followed"):
        parse_hydrodynamics(body_urdf(hydro_plugin("<disable_coriolis>1</disable_coriolis>")))


@pytest.mark.parametrize("extra, message", [
    ("<xV>-1</xV>", "<xV> is off the diagonal"), ("<yUabsV>-1</yUabsV>", "<yUabsV> is off the diagonal"),
    ("<xUU>-1</xUU>", "<xUU> .a signed quadratic term. is not supported"),
])
def test_damping_uvms_cannot_model_is_refused(extra, message):
    with pytest.raises(ModelCheckError, match=message):
        parse_hydrodynamics(body_urdf(hydro_plugin(extra)), "gz.urdf")
    with pytest.raises(ModelCheckError, match="hold positive values"):
        parse_hydrodynamics(body_urdf(hydro_plugin().replace("<xU>-3.0<", "<xU>3.0<")), "gz.urdf")


def test_the_buoyancy_system_gives_the_fluid_density():
    plugin = ET.fromstring('<plugin filename="gz-sim-buoyancy-system" name="gz::sim::systems::Buoyancy">'
                           '<uniform_fluid_density>997</uniform_fluid_density></plugin>')
    assert gz_buoyancy_density(plugin, "w") == 997.0
    hydro = parse_hydrodynamics(body_urdf(hydro_plugin() + ET.tostring(plugin, encoding="unicode")))
    assert hydro.fluid_density == 997.0
    graded = ET.fromstring('<plugin filename="gz-sim-buoyancy-system" name="b"><graded_buoyancy><default_density>1025'
                           '</default_density><density_change><above_depth>0</above_depth><density>1</density>'
                           '</density_change></graded_buoyancy></plugin>')
    with pytest.warns(PluginSettingWarning, match="layers of <graded_buoyancy> are not modelled"):
        assert gz_buoyancy_density(graded, "w") == 1025.0


# ------------------------------------------------------------------ the blue package, use_sim:=true
@pytest.fixture(scope="module")
def blue() -> uvms.Robot:
    with pytest.warns(uvms.errors.BaseGuessWarning, match="'base_footprint' and the links fixed to it carry 13 kg "
                                                          "and 8 propeller joint"):
        return uvms.load(FIXTURES / "bluerov2_heavy_sim.urdf")


def test_blue_with_use_sim_has_eight_thrusters_along_their_joint_axes_and_its_damping(blue):
    """Each thruster pushes along its propeller joint's axis (0 0 -1 in the joint frame, turned by the joint's rpy)
    at the joint's origin; the limits and lag come from thrusters.yaml beside it; the damping is -<xUabsU> ..."""
    assert blue.base_type == "floating" and blue.n_arm == 0
    thrusters = thrusters_of(blue)
    assert thrusters.names == [f"thruster{i}_joint" for i in range(1, 9)]
    points, directions = placements_in_base(blue, thrusters)
    root = ET.parse(FIXTURES / "bluerov2_heavy_sim.urdf").getroot()
    for joint, point, direction in zip([j for j in root.findall("joint") if j.get("type") == "continuous"],
                                       points, directions):
        origin = joint.find("origin")
        rotation = pin.rpy.rpyToMatrix(*map(float, origin.get("rpy").split()))
        np.testing.assert_allclose(point, [float(x) for x in origin.get("xyz").split()], atol=1e-12)
        np.testing.assert_allclose(direction, rotation @ [0.0, 0.0, -1.0], atol=1e-12)
    assert directions[0] == pytest.approx([-0.7071, -0.7075, 0.0], abs=1e-3)  # rpy -1.571 1.571 -0.785
    assert thrusters.upper.tolist() == [51.5] * 8 and thrusters.lower.tolist() == [-40.2] * 8
    assert thrusters.time_constants.tolist() == [0.1] * 8
    hydro = hydrodynamics_of(blue)
    (link,) = hydro.links.values()
    assert list(hydro.links) == ["base_footprint"]
    np.testing.assert_allclose(link.quadratic_damping, [58.42, 55.137, 124.818, 4.0, 4.0, 4.0])
    assert not link.added_mass.any() and not link.linear_damping.any()
    text = describe(blue)
    assert "thrusters (8) from" in text and "allocation  every body-wrench direction (rank 6)" in text
    assert "from the Gazebo Sim hydrodynamics plugin blocks of" in text
    assert "thruster1_joint          Gazebo Sim thruster plugin 'thruster1_joint' names it (<joint_name>)" in text


def test_blue_holds_station_with_its_gz_plugins(tmp_path):
    with pytest.warns(uvms.errors.BaseGuessWarning):
        run = run_scenario(FIXTURES / "blue_station.toml", out=tmp_path / "out", progress=False)
    assert run.metrics["verdict"]["ok"]
    assert 1e-4 < run.metrics["vehicle_position_error"] < 0.02 and run.metrics["saturated_time_fraction"] == 0.0
    assert not math.isnan(run.metrics["max_position_error"])
