"""The dynamic plant (uvms.dynamics.plant.plant) with a mimic joint: a gripper whose second finger mimics the first.

The oracle is the same URDF without the ``<mimic>`` tag (every joint free, built independently here), mapped
through the mimic relation written in the file: q_full = q with finger_b = MULTIPLIER q_a + OFFSET,
v_full = G v, M = G^T M_full G, h = G^T h_full (G: (nv_full, nv), the identity with finger_b's row holding the
multiplier in finger_a's column).
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.control import OpenLoop
from uvms.dynamics.hydro.hydrodynamics import HydroParameters, LinkHydrodynamics
from uvms.dynamics.plant.plant import Plant
from uvms.scenario import run_scenario
from uvms.sim import simulate

from conftest import ROOT

MULTIPLIER, OFFSET = -1.5, 0.2


def inertial(mass: float, com: str) -> str:
    return (f'<inertial><origin xyz="{com}"/><mass value="{mass}"/>'
            f'<inertia ixx="0.01" iyy="0.02" izz="0.015" ixy="0" ixz="0" iyz="0"/></inertial>')


#: A 10 kg hull, a shoulder, and a gripper: finger_b mimics finger_a (both revolute, off-centre masses, so the
#: mimic finger's weight and inertia matter). ``tip_b`` is a frame on the mimic finger.
MIMIC_URDF = f"""<robot name="mimic_gripper">
  <link name="world"/>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull"/></joint>
  <link name="hull"><inertial><mass value="10"/>
    <inertia ixx="0.3" iyy="0.4" izz="0.5" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="hull"/><child link="arm"/><origin xyz="0.3 0 -0.1"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="2"/></joint>
  <link name="arm">{inertial(2.0, "0.2 0 0")}</link>
  <joint name="finger_a" type="revolute"><parent link="arm"/><child link="link_a"/><origin xyz="0.4 0.05 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="10" velocity="2"/></joint>
  <link name="link_a">{inertial(0.8, "0.1 0.02 0")}</link>
  <joint name="finger_b" type="revolute"><parent link="arm"/><child link="link_b"/><origin xyz="0.4 -0.05 0"/>
    <axis xyz="0 0 1"/><limit lower="-4" upper="4" effort="10" velocity="3"/>
    <mimic joint="finger_a" multiplier="{MULTIPLIER}" offset="{OFFSET}"/></joint>
  <link name="link_b">{inertial(0.6, "0.12 -0.03 0.01")}</link>
  <joint name="tip_b_joint" type="fixed"><parent link="link_b"/><child link="tip_b"/><origin xyz="0.15 0 0"/></joint>
  <link name="tip_b"/>
</robot>"""


@pytest.fixture(scope="module")
def robots() -> tuple[uvms.Robot, uvms.Robot]:
    """(the mimic model, the full tree: the same file without its mimic tag)."""
    full = re.sub(r"<mimic [^>]*/>", "", MIMIC_URDF)
    assert full != MIMIC_URDF
    return uvms.load(MIMIC_URDF), uvms.load(full)


def full_state(mimic: uvms.Robot, full: uvms.Robot, q: np.ndarray, v: np.ndarray):
    """(q_full, v_full, G): finger_b set by the mimic relation; the other joints copied by name."""
    q_full, G = np.zeros(full.nq), np.zeros((full.nv, mimic.nv))
    by_name = {joint.name: joint for joint in mimic.joints}
    for joint in full.joints:
        source = by_name[joint.name if joint.name != "finger_b" else "finger_a"]
        span = slice(source.idx_q, source.idx_q + source.nq)
        if joint.name == "finger_b":
            q_full[joint.idx_q] = MULTIPLIER * q[source.idx_q] + OFFSET
            G[joint.idx_v, source.idx_v] = MULTIPLIER
        else:
            q_full[joint.idx_q:joint.idx_q + joint.nq] = q[span]
            G[joint.idx_v:joint.idx_v + joint.nv, source.idx_v:source.idx_v + source.nv] = np.eye(joint.nv)
    return q_full, G @ v, G


def random_state(robot: uvms.Robot, rng) -> tuple[np.ndarray, np.ndarray]:
    q = robot.configuration(base=rng.normal(size=6) * 0.4, arm=rng.uniform(-1.0, 1.0, size=robot.n_arm))
    return q, rng.normal(size=robot.nv) * 0.5


def hydro(current=(0.0, 0.0, 0.0)) -> HydroParameters:
    """Buoyancy, added mass and damping on the hull and on both fingers (the mimic one included)."""
    def link(volume, scale):
        added = scale * (np.diag([1.0, 2.0, 3.0, 0.02, 0.03, 0.04]) + 0.1 * np.eye(6, k=4) + 0.1 * np.eye(6, k=-4))
        return LinkHydrodynamics(volume=volume, center_of_buoyancy=[0.01, -0.02, 0.03], added_mass=added,
                                 linear_damping=[2.0, 3.0, 4.0, 0.1, 0.2, 0.3] * np.full(6, scale),
                                 quadratic_damping=[5.0, 6.0, 7.0, 0.2, 0.3, 0.4] * np.full(6, scale))
    return HydroParameters(fluid_density=1000.0, current=np.asarray(current),
                           links={"hull": link(0.011, 1.0), "link_a": link(0.0007, 0.1), "link_b": link(0.0005, 0.1)})


def test_the_mimic_model_has_the_driver_coordinates_only(robots):
    mimic, full = robots
    assert (mimic.nq, mimic.nv, mimic.n_arm) == (full.nq - 1, full.nv - 1, 2)
    mimic_joint = mimic.model.joints[mimic.model.getJointId("finger_b")].extract()
    assert (mimic_joint.scaling, mimic_joint.offset) == (MULTIPLIER, OFFSET)  # Pinocchio keeps the file's relation


def test_mass_matrix_and_bias_are_the_full_trees_through_the_mimic_relation(robots, rng):
    """Mbar and nbar of the plant with gravity, buoyancy, added mass, damping and a current on every link (the
    mimic finger's too) equal G^T Mbar_full G and G^T nbar_full of the full tree at q_full, G v."""
    mimic, full = robots
    plants = [Plant(robot, hydro([0.2, -0.1, 0.05]), gravity=True) for robot in robots]
    for _ in range(3):
        q, v = random_state(mimic, rng)
        q_full, v_full, G = full_state(mimic, full, q, v)
        np.testing.assert_allclose(mimic.fk(q, "tip_b").homogeneous, full.fk(q_full, "tip_b").homogeneous, atol=1e-12)
        mass, bias = plants[0]._mass_and_bias(q, v)
        mass_full, bias_full = plants[1]._mass_and_bias(q_full, v_full)
        np.testing.assert_allclose(mass, G.T @ mass_full @ G, atol=1e-12)
        np.testing.assert_allclose(bias, G.T @ bias_full, atol=1e-10)
        assert np.abs(bias[6:]).max() > 0.1  # the arm rows are not trivially zero


def test_energies_and_momentum_are_the_full_trees(robots, rng):
    mimic, full = robots
    plants = [Plant(robot, hydro(), gravity=True) for robot in robots]
    q, v = random_state(mimic, rng)
    q_full, v_full, _ = full_state(mimic, full, q, v)
    np.testing.assert_allclose(plants[0].energy(q, v), plants[1].energy(q_full, v_full), rtol=1e-12)
    np.testing.assert_allclose(plants[0].momentum(q, v), plants[1].momentum(q_full, v_full), atol=1e-12)
    # the weight's potential against Pinocchio's own on the full tree (which has no mimic to refuse)
    model = plants[1].model
    expected = pin.computePotentialEnergy(model, model.createData(), q_full)
    buoyancy = sum(plants[1].hydro.fluid_density * plants[1].hydro.gravity * link.params.volume
                   * (full.fk(q_full, link.name) * pin.SE3(np.eye(3), link.params.center_of_buoyancy)).translation[2]
                   for link in plants[1].links)
    assert plants[0].energy(q, v)[1] == pytest.approx(expected - buoyancy, rel=1e-12)


def test_the_energy_rate_is_the_motor_power(robots, rng):
    """Gravity, no hydrodynamics: d(kinetic + potential)/dt = tau_m . qd_m along the plant's own motion (central
    differences, step 1e-5 s)."""
    mimic, _ = robots
    plant = Plant(mimic, HydroParameters(), gravity=True, damping=False, added_mass=False)
    q, v = random_state(mimic, rng)
    command = rng.normal(size=mimic.n_arm)
    dynamics = plant.evaluate(q, v, command)
    h = 1e-5
    energies = [sum(plant.energy(pin.integrate(mimic.model, q, sign * h * v + 0.5 * h * h * dynamics.acceleration),
                                 v + sign * h * dynamics.acceleration)) for sign in (1.0, -1.0)]
    rate = (energies[0] - energies[1]) / (2 * h)
    power = float(dynamics.joint_torque @ v[6:])
    assert abs(power) > 0.1
    assert rate == pytest.approx(power, rel=1e-6, abs=1e-8)


def test_a_passive_plant_with_a_mimic_gripper_conserves_its_energy(robots):
    """Arm locked (zero command, at rest), gravity on, no hydrodynamics: the UVMS falls and tumbles; kinetic +
    potential stays constant to RK4 accuracy while 15 J go from potential to kinetic."""
    mimic, _ = robots
    plant = Plant(mimic, HydroParameters(), gravity=True, damping=False, added_mass=False)
    q0 = mimic.configuration(base=[0.0, 0.0, 0.0, 0.3, -0.2, 0.1], arm=[0.4, 0.7])
    v0 = np.concatenate([[0.1, -0.2, 0.3, 0.8, -0.5, 0.6], np.zeros(mimic.n_arm)])
    result = simulate(plant, None, q0, 0.5, 0.002, v0=v0)
    energy = result.plant.energy
    assert np.ptp(result.plant.kinetic_energy) > 15.0
    assert np.ptp(energy) < 1e-8 * np.ptp(result.plant.kinetic_energy)


def test_momentum_is_conserved_with_the_mimic_finger_swinging(robots):
    """No gravity, current or damping, added mass on the fingers: the joints swing and the (added-mass-augmented)
    momentum stays put."""
    mimic, _ = robots
    fluid = hydro()
    still = HydroParameters(fluid_density=fluid.fluid_density, links={
        name: LinkHydrodynamics(added_mass=link.added_mass) for name, link in fluid.links.items()})
    plant = Plant(mimic, still, gravity=False, damping=False, added_mass=True)
    q0 = mimic.configuration(arm=[0.3, -0.4])
    result = simulate(plant, OpenLoop(arm=lambda t: np.array([0.8 * np.sin(3 * t), 1.5 * np.cos(5 * t)])), q0, 1.0,
                      0.002)
    assert np.ptp(result.v[:, 7]) > 1.0  # the finger really swings
    assert np.max(result.plant.momentum_drift()) < 1e-9


def test_the_generalized_jacobian_of_a_mimic_frame_is_momentum_conservation(robots, rng):
    """GJM qd_m is the twist of a frame on the mimic finger when the vehicle moves so that the full tree's momentum
    (its centroidal map, times G) stays zero; the twist by finite differences of the pose."""
    mimic, full = robots
    q, _ = random_state(mimic, rng)
    arm_rates = rng.normal(size=mimic.n_arm)
    q_full, _, G = full_state(mimic, full, q, np.zeros(mimic.nv))
    centroidal = pin.computeCentroidalMap(full.model, full.model.createData(), q_full) @ G  # (6, nv)
    vehicle = -np.linalg.solve(centroidal[:, :6], centroidal[:, 6:] @ arm_rates)
    v = np.concatenate([vehicle, arm_rates])
    h = 1e-6
    poses = [mimic.fk(pin.integrate(mimic.model, q, sign * h * v), "tip_b") for sign in (1.0, -1.0)]
    linear = (poses[0].translation - poses[1].translation) / (2 * h)
    angular = pin.log3(poses[0].rotation @ poses[1].rotation.T) / (2 * h)
    twist = mimic.generalized_jacobian(q, "tip_b") @ arm_rates
    np.testing.assert_allclose(twist, np.concatenate([linear, angular]), atol=1e-7)
    assert np.linalg.norm(vehicle) > 1e-2  # the vehicle does react


def test_the_station_keeping_scenario_with_a_mimic_gripper_runs_with_gravity(tmp_path):
    """The plant crashed there (``computePotentialEnergy``: 'does not support Joint Mimic type')."""
    scenario = ROOT / "tests" / "fixtures" / "rexrov_like" / "station_current.toml"
    result = run_scenario(scenario, tmp_path / "run", ["outputs.figures=false", "trajectory.duration=0.2"],
                          progress=False)
    assert result.metrics["plant"] == "hydrodynamic" and result.scenario.plant.gravity is True
    potential = result.simulation.plant.potential_energy
    assert len(potential) == 21 and np.all(np.isfinite(potential)) and np.ptp(potential) > 0.0
