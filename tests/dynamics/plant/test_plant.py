"""The free-floating plant (uvms.dynamics.plant.plant): conservation laws, the added-mass GJM, hydrostatics, damping,
motors, parsing."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import uvms
from uvms.control import OpenLoop
from uvms.dynamics.hydro.hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of, parse_hydrodynamics
from uvms.dynamics.plant.added_mass import generalized_jacobian_added_mass
from uvms.dynamics.plant.plant import Plant
from uvms.errors import ModelCheckError, ModelParseError, SkippedLinkWarning, UVMSError
from uvms.sim import simulate

from conftest import body_urdf, shipped

RHO = 1000.0
G = 9.81


def diagonal_text(values):
    return " ".join(str(x) for x in np.diag(values).ravel())


def hull(**kwargs) -> uvms.Robot:
    return uvms.load(body_urdf(**kwargs))


def swinging_command(n_arm, amplitude=0.5):
    """Smooth joint-velocity commands, a different frequency per joint [rad/s]."""
    rates = np.arange(1, n_arm + 1)
    return OpenLoop(arm=lambda t: amplitude * np.sin(rates * t + 0.3))


# ------------------------------------------------------------- conservation
def test_rigid_momentum_is_conserved_and_its_drift_shrinks_like_dt4():
    robot = shipped("amundsen2018")
    plant = Plant(robot, added_mass=False, damping=False, gravity=False)
    q0 = robot.configuration(arm=0.3 * np.ones(robot.n_arm))
    drifts = []
    for dt in (0.02, 0.01):
        result = simulate(plant, swinging_command(robot.n_arm), q0, 2.0, dt)
        drifts.append(np.max(result.plant.momentum_drift()))
    moved = np.linalg.norm(result.q[-1, :3] - result.q[0, :3])
    assert moved > 1e-2  # the joints really pushed the base around
    assert drifts[1] <= 1e-5  # [N s, N m s]; the swinging modules carry momenta of order 1 N s
    assert drifts[0] / drifts[1] > 10.0  # fourth order: 16 in the limit


def test_a_coasting_locked_uvms_keeps_its_energy_and_momentum_with_added_mass():
    robot = shipped("bluerov2_alpha5")
    plant = Plant(robot, added_mass=True, damping=False, gravity=False)
    q0 = robot.configuration(arm=[np.pi, 1.0, 1.5, 0.5, 0.0])
    v0 = np.concatenate([[0.3, -0.1, 0.2, 0.4, -0.6, 0.8], np.zeros(robot.n_arm)])
    result = simulate(plant, None, q0, 2.0, 0.005, v0=v0)
    assert np.allclose(result.v[:, 6:], 0.0)  # motors hold a zero command: the arm stays locked
    assert np.ptp(result.plant.kinetic_energy) <= 1e-8 * result.plant.kinetic_energy[0]
    assert np.max(result.plant.momentum_drift()) <= 1e-8 * np.max(np.abs(result.plant.momentum[0]))
    assert np.ptp(result.v[:, 3:6], axis=0).max() > 0.1  # it tumbles: C_A and C_RB are at work


def test_added_mass_momentum_is_conserved_and_the_added_mass_gjm_is_exact():
    robot = shipped("amundsen2018")
    plant = Plant(robot, added_mass=True, damping=False, gravity=False)
    q0 = robot.configuration(arm=0.3 * np.ones(robot.n_arm))
    result = simulate(plant, swinging_command(robot.n_arm), q0, 2.0, 0.005)
    assert np.max(result.plant.momentum_drift()) <= 1e-6
    twists = result.ee_twist()
    worst_added = worst_rigid = 0.0
    for q, v, twist in zip(result.q[::20], result.v[::20], twists[::20]):
        arm_rates = v[robot.n_vehicle:]
        added_mass_gjm = generalized_jacobian_added_mass(robot, None, q)
        worst_added = max(worst_added, np.linalg.norm(twist - added_mass_gjm @ arm_rates))
        worst_rigid = max(worst_rigid, np.linalg.norm(twist - robot.generalized_jacobian(q) @ arm_rates))
    scale = np.max(np.linalg.norm(twists, axis=1))
    assert scale > 0.05  # [m/s, rad/s]: the head really moved
    assert worst_added <= 1e-6 * scale
    assert worst_rigid >= 1e-2 * scale  # the rigid GJM ignores the water the modules push


@pytest.mark.parametrize("name", ["amundsen2018", "bluerov2_alpha5"])
def test_the_added_mass_gjm_is_the_rigid_gjm_without_added_mass(name, rng):
    robot = shipped(name)
    hydro = hydrodynamics_of(robot)
    without = HydroParameters(links={link: LinkHydrodynamics(volume=p.volume, center_of_buoyancy=p.center_of_buoyancy)
                                     for link, p in hydro.links.items()})
    for _ in range(3):
        q = robot.random_configuration(rng)
        rigid = robot.generalized_jacobian(q)
        assert np.allclose(generalized_jacobian_added_mass(robot, without, q), rigid, atol=1e-12)
        assert np.allclose(generalized_jacobian_added_mass(robot, HydroParameters(), q), rigid, atol=1e-12)
        assert np.allclose(Plant(robot, added_mass=True).generalized_jacobian(q),
                           generalized_jacobian_added_mass(robot, hydro, q), atol=1e-12)
        assert not np.allclose(generalized_jacobian_added_mass(robot, hydro, q), rigid, atol=1e-3)


# ------------------------------------------------------------- hydrostatics
def roll_of(q):
    qx, qy, qz, qw = q[3:7]
    return np.arctan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy))


def test_a_neutral_vehicle_with_its_buoyancy_above_its_weight_rights_itself():
    robot = hull(cob_z=0.02, added=diagonal_text([5, 5, 5, 0.1, 0.1, 0.1]), linear="0 0 0 -0.5 -0.5 -0.5")
    plant = Plant(robot, gravity=True)
    q0 = robot.configuration(base=[0, 0, 0, 0.4, 0, 0])
    start = plant.acceleration(q0, np.zeros(6), np.zeros(0))
    # restoring moment m g z_b sin(roll) against the roll, about body x, over I_xx + K_p'
    assert start[3] == pytest.approx(-10.0 * G * 0.02 * np.sin(0.4) / (0.3 + 0.1), rel=1e-12)
    assert np.allclose(start[[0, 1, 2, 4, 5]], 0.0, atol=1e-12)  # neutral: no net force
    result = simulate(plant, None, q0, 10.0, 0.02)
    rolls = np.array([roll_of(q) for q in result.q])
    assert rolls.min() < 0.0 < rolls.max()  # it swings through upright
    assert abs(rolls[-1]) < 0.01 and np.abs(result.q[-1, :3]).max() < 1e-9


def test_a_buoyant_vehicle_rises_with_its_added_mass_in_the_inertia():
    robot = hull(volume=1.1 * 10.0 / RHO, added=diagonal_text([2, 3, 4, 0.1, 0.1, 0.1]))
    plant = Plant(robot, gravity=True, damping=False)
    heave = plant.acceleration(robot.neutral(), np.zeros(6), np.zeros(0))
    assert heave[2] == pytest.approx((1.1 - 1.0) * 10.0 * G / (10.0 + 4.0), rel=1e-12)
    result = simulate(plant, None, robot.neutral(), 1.0, 0.01)
    assert result.q[-1, 2] == pytest.approx(0.5 * heave[2], rel=1e-9)
    assert np.allclose(np.diff(result.plant.energy), 0.0, atol=1e-9)  # buoyancy is conservative
    weightless = Plant(robot, gravity=False)
    assert weightless.acceleration(robot.neutral(), np.zeros(6), np.zeros(0)) == pytest.approx(np.zeros(6))


def restoring_wrench(plant, q):
    """World wrench about the origin (6,) of the weights and buoyancies at q, summed independently of the plant."""
    import pinocchio as pin

    model, data = plant.model, plant.model.createData()
    pin.forwardKinematics(model, data, q)
    wrench = np.zeros(6)
    def add(point, force):
        wrench[:3] += force
        wrench[3:] += np.cross(point, force)
    for joint in range(1, model.njoints):
        inertia = model.inertias[joint]
        add(data.oMi[joint].act(inertia.lever), np.array([0.0, 0.0, -inertia.mass * G]))
    for link in plant.links:
        pose = data.oMi[link.joint_id] * link.placement
        add(pose.act(link.params.center_of_buoyancy), np.array([0.0, 0.0, RHO_SEA * G * link.params.volume]))
    return wrench


RHO_SEA = 1028.0


def test_the_momentum_changes_at_the_rate_of_the_restoring_wrench():
    robot = shipped("bluerov2_alpha5")
    plant = Plant(robot, gravity=True, damping=False, added_mass=True)
    q0 = robot.configuration(base=[0, 0, 0, 0.3, -0.2, 0.5], arm=[np.pi, 1.0, 1.5, 0.5, 0.005])
    dt = 1e-3
    result = simulate(plant, swinging_command(robot.n_arm), q0, 0.2, dt)
    rate = (result.plant.momentum[2:] - result.plant.momentum[:-2]) / (2 * dt)  # central differences [N, N m]
    expected = np.array([restoring_wrench(plant, q) for q in result.q[1:-1]])
    assert np.abs(expected[:, 3:]).max() > 0.1  # the arm's weight and the offset buoyancy do tilt it
    assert np.allclose(rate, expected, atol=1e-5 * np.abs(expected).max())
    assert np.allclose(expected[:, 2], 0.0, atol=1e-10)  # the trimmed UVMS is neutral


def test_the_shipped_uvms_are_neutrally_buoyant():
    for name in ("amundsen2018", "bluerov2_alpha5"):
        robot = shipped(name)
        hydro = hydrodynamics_of(robot)
        displaced = hydro.fluid_density * sum(link.volume for link in hydro.links.values())
        assert displaced == pytest.approx(robot.total_mass, rel=1e-12)


# ------------------------------------------------------------------ damping
def test_linear_and_quadratic_damping_follow_the_closed_form_coast():
    mass, added, linear, quadratic, u0 = 10.0, 2.0, 3.0, 40.0, 1.5
    robot = hull(added=diagonal_text([added, 5, 5, 0.1, 0.1, 0.1]),
                 linear=f"{-linear} 0 0 0 0 0", quadratic=f"{-quadratic} 0 0 0 0 0")
    result = simulate(Plant(robot), None, robot.neutral(), 2.0, 0.01, v0=[u0, 0, 0, 0, 0, 0])
    inertia = mass + added  # (m + X_u') u' = -(k u + d u^2)
    decay = np.exp(-linear * result.t / inertia)
    expected = linear * u0 * decay / (linear + quadratic * u0 * (1.0 - decay))
    assert np.allclose(result.v[:, 0], expected, rtol=1e-6, atol=0)  # RK4 at h |df/du| <= 0.1
    assert np.allclose(result.v[:, 1:], 0.0, atol=1e-14)


def test_a_damped_body_drifts_with_the_current():
    robot = hull(added=diagonal_text([2, 3, 4, 0.1, 0.1, 0.1]), linear="-20 -20 -20 -1 -1 -1",
                 quadratic="-40 -40 -40 -1 -1 -1")
    current = np.array([0.3, -0.2, 0.1])
    plant = Plant(robot, current=current)
    q0 = robot.configuration(base=[0, 0, 0, 0.2, -0.1, 1.0])
    result = simulate(plant, None, q0, 10.0, 0.05)
    velocity_world = robot.base_pose(result.q[-1]).rotation @ result.v[-1, :3]
    assert np.allclose(velocity_world, current, atol=1e-6)  # relative velocity decays in ~0.7 s


def test_a_coasting_bluerov_slows_down():
    robot = shipped("bluerov2_alpha5")
    q0 = robot.configuration(arm=[np.pi, 1.0, 1.5, 0.5, 0.0])
    v0 = np.concatenate([[0.5, 0.2, -0.1, 0.0, 0.0, 0.3], np.zeros(robot.n_arm)])
    result = simulate(Plant(robot), None, q0, 3.0, 0.01, v0=v0)
    speed = np.linalg.norm(result.v[:, :3], axis=1)
    assert speed[-1] < 0.35 * speed[0]
    assert np.all(np.diff(result.plant.kinetic_energy) < 0.0)  # damping only removes energy


# -------------------------------------------------------------------- motors
def test_the_joint_motors_are_first_order_lags():
    robot = shipped("bluerov2_alpha5")
    tau, step = 0.1, np.array([0.3, -0.2, 0.25, 0.4, 0.001])
    plant = Plant(robot, motor_time_constant=tau)
    q0 = robot.configuration(arm=[np.pi, 1.0, 1.5, 0.5, 0.005])
    result = simulate(plant, OpenLoop(arm=step), q0, 5 * tau, tau / 20)
    at_tau = result.v[np.argmin(np.abs(result.t - tau)), 6:]
    assert np.allclose(at_tau / step, 1.0 - np.exp(-1.0), rtol=1e-7)  # 63.2 % at t = tau
    assert np.allclose(result.v[-1, 6:] / step, 1.0 - np.exp(-5.0), rtol=1e-7)
    assert np.abs(result.v[:, :6]).max() > 1e-3  # the reaction moves the vehicle


# ------------------------------------------------------------------- parsing
def test_values_round_trip_from_uuv_simulator_form():
    added = np.diag([2.0, 3.0, 4.0, 0.5, 0.6, 0.7])
    added[0, 4] = added[4, 0] = 0.2  # surge-pitch coupling: flips sign between SNAME and ROS axes
    added[1, 5] = added[5, 1] = 0.3  # sway-yaw coupling: the same in both
    text = body_urdf(cob_z=0.05, added=" ".join(map(str, added.ravel())), linear="-1 -2 -3 -4 -5 -6",
                     quadratic=diagonal_text([-7, -8, -9, -10, -11, -12]))
    hydro = parse_hydrodynamics(text)
    link = hydro.links["hull"]
    assert hydro.fluid_density == RHO and link.volume == pytest.approx(10.0 / RHO)
    assert np.array_equal(link.center_of_buoyancy, [0, 0, 0.05])
    assert link.added_mass[0, 4] == -0.2 and link.added_mass[1, 5] == 0.3
    assert np.array_equal(np.diag(link.added_mass), np.diag(added))
    assert np.array_equal(link.linear_damping, [1, 2, 3, 4, 5, 6])
    assert np.array_equal(link.quadratic_damping, [7, 8, 9, 10, 11, 12])
    assert parse_hydrodynamics(uvms.model.example_robot_urdf("ur5").read_text()) is None


def test_neutrally_buoyant_takes_the_volume_from_the_link_mass():
    text = body_urdf(volume=0.5).replace("<volume>", "<neutrally_buoyant>1</neutrally_buoyant><volume>")
    assert parse_hydrodynamics(text).links["hull"].volume == pytest.approx(10.0 / RHO)


@pytest.mark.parametrize("change, message", [
    ({"added": "1 2 3"}, "added_mass holds 3 numbers, expected 36"),
    ({"linear": "-1 -2 -3 -4 -5"}, "linear_damping holds 5 numbers"),
    ({"quadratic": "-1 -2 3 -4 -5 -6"}, "negate them"),
    ({"added": "1 0.5" + " 0" * 5 + " 1" + " 0 0 0 0 0 0 1" * 4}, "must be symmetric"),
    ({"added": diagonal_text([1, 1, -1, 1, 1, 1])}, "positive semi-definite"),
    ({"volume": "-0.1"}, "volume must be >= 0"),
    ({"volume": "nan"}, "non-finite"),
    ({"kind": "ellipsoid"}, "valid: fossen, sphere, cylinder, spheroid, box"),
])
def test_bad_hydrodynamic_values_are_refused(change, message):
    with pytest.raises(ModelCheckError, match=message) as error:
        parse_hydrodynamics(body_urdf(**change), "probe.urdf")
    assert "probe.urdf: hydrodynamics of link 'hull'" in str(error.value)


def test_a_block_of_an_unknown_link_is_skipped_with_a_warning_naming_it():
    """As Gazebo does (DAVE's RexROV names 'oberon7/base'): the block is skipped, its values unread; the warning names
    the link and the close names; made an error (uvms --strict), it refuses the model."""
    extra = "<link name='hul'><volume>not a number</volume></link>"
    robot = uvms.load(body_urdf(extra_link=extra))
    with pytest.warns(SkippedLinkWarning, match="hydrodynamics of link 'hul': the model has no link 'hul'; close "
                                                "names: hull; the block is skipped"):
        plant = Plant(robot)
    assert list(plant.hydro.links) == ["hull"] and plant.hydro.links["hull"].volume > 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", SkippedLinkWarning)
        with pytest.raises(SkippedLinkWarning, match="'hul'"):
            Plant(robot)
    with pytest.raises(ModelCheckError, match="given twice"):
        parse_hydrodynamics(body_urdf(extra_link="<link name='hull'/>"))


def test_the_dataclass_checks_its_values():
    with pytest.raises(ModelCheckError, match="linear_damping coefficients must be >= 0"):
        LinkHydrodynamics(linear_damping=[1, 1, -1, 1, 1, 1])
    with pytest.raises(ModelCheckError, match=r"center_of_buoyancy must have shape \(3,\)"):
        LinkHydrodynamics(center_of_buoyancy=[0, 0])
    with pytest.raises(ModelCheckError, match="fluid_density must be > 0"):
        HydroParameters(fluid_density=0.0)
    assert LinkHydrodynamics(added_mass=np.eye(6).ravel()).added_mass.shape == (6, 6)


YAML = """fluid_density: 1000.0
current: [0.1, 0.0, 0.0]
links:
  hull:
    volume: 0.011
    center_of_buoyancy: [0.0, 0.0, 0.05]
    hydrodynamic_model:
      type: fossen
      added_mass: [[2, 0, 0, 0, 0.2, 0], [0, 3, 0, 0, 0, 0], [0, 0, 4, 0, 0, 0],
                   [0, 0, 0, 0.5, 0, 0], [0.2, 0, 0, 0, 0.6, 0], [0, 0, 0, 0, 0, 0.7]]
      linear_damping: [-1, -2, -3, -4, -5, -6]
      quadratic_damping: [-7, -8, -9, -10, -11, -12]
"""


def test_a_yaml_beside_the_model_is_read_in_the_same_conventions(tmp_path):
    plain = body_urdf()
    start = plain.index("<gazebo>")
    (tmp_path / "hull.urdf").write_text(plain[:start] + "</robot>")
    (tmp_path / "hydrodynamics.yaml").write_text(YAML)
    hydro = hydrodynamics_of(uvms.load(tmp_path / "hull.urdf"))
    link = hydro.links["hull"]
    assert (link.volume, link.added_mass[0, 4], link.added_mass[2, 2]) == (0.011, -0.2, 4.0)
    assert np.array_equal(link.quadratic_damping, [7, 8, 9, 10, 11, 12])
    assert np.array_equal(hydro.current, [0.1, 0.0, 0.0])
    (tmp_path / "both.urdf").write_text(plain)
    with pytest.raises(UVMSError, match="both in the model"):
        hydrodynamics_of(uvms.load(tmp_path / "both.urdf"))
    chosen = hydrodynamics_of(uvms.load(tmp_path / "both.urdf"), tmp_path / "hydrodynamics.yaml")
    assert chosen.links["hull"].volume == 0.011
    (tmp_path / "bad.yaml").write_text(YAML.replace("volume:", "volum:"))
    with pytest.raises(ModelParseError, match="unknown key.*volum; valid: volume"):
        hydrodynamics_of(uvms.load(tmp_path / "hull.urdf"), tmp_path / "bad.yaml")


def test_plant_arguments_are_checked():
    robot = shipped("bluerov2_alpha5")
    with pytest.raises(UVMSError, match="fixed base"):
        Plant(uvms.load(uvms.model.example_robot_urdf("ur5")))
    with pytest.raises(UVMSError, match="motor_time_constant"):
        Plant(robot, motor_time_constant=0.0)
    with pytest.raises(UVMSError, match="5 finite joint velocities"):
        simulate(Plant(robot), OpenLoop(arm=np.zeros(3)), robot.neutral(), 0.1, 0.01)
    with pytest.raises(UVMSError, match="unknown integrator 'rk45'; valid: euler, rk4"):
        simulate(Plant(robot), None, robot.neutral(), 0.1, 0.01, integrator="rk45")
    with pytest.raises(UVMSError, match="no hydrodynamic parameters"):
        hydrodynamics_of(shipped("hoang2011"))


def fossen_terms_link_by_link(plant: Plant, q: np.ndarray, v: np.ndarray, body_wrench: np.ndarray):
    """Mbar and nbar written link by link as the module docstring derives them: each link's wrench from its own
    Pinocchio frame quantities (placement, velocity, bias acceleration, pose), applied as an external force in
    ``pin.rnea`` (an independent path from the plant's compiled sum of J_l^T f_l)."""
    import pinocchio as pin

    model = plant.model
    data = model.createData()
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.computeJointJacobians(model, data)
    mass = pin.crba(model, model.createData(), q)
    mass = np.triu(mass) + np.triu(mass, 1).T
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    hydro = plant.hydro
    for link in plant.links:
        pose = data.oMi[link.joint_id] * link.placement
        nu = link.placement.actInv(data.v[link.joint_id]).vector
        bias = link.placement.actInv(data.a[link.joint_id]).vector
        current = pose.rotation.T @ hydro.current
        nu_r = nu - np.concatenate([current, np.zeros(3)])
        current_rate = np.concatenate([-np.cross(nu[3:], current), np.zeros(3)])
        params = link.params
        jacobian = pin.getFrameJacobian(model, data, link.frame_id, pin.LOCAL)
        mass += jacobian.T @ params.added_mass @ jacobian
        a = params.added_mass @ nu_r
        coriolis = np.concatenate([np.cross(nu_r[3:], a[:3]), np.cross(nu_r[:3], a[:3]) + np.cross(nu_r[3:], a[3:])])
        wrench = -params.added_mass @ (bias - current_rate) - coriolis + params.damping_wrench(nu_r)
        buoyancy = pose.rotation.T @ np.array([0.0, 0.0, hydro.fluid_density * hydro.gravity * params.volume])
        wrench += np.concatenate([buoyancy, np.cross(params.center_of_buoyancy, buoyancy)])
        fext[link.joint_id] += link.placement.act(pin.Force(wrench))
    fext[1] += plant.robot.base_placement.act(pin.Force(body_wrench))
    return mass, pin.rnea(model, model.createData(), q, v, np.zeros(model.nv), fext)


@pytest.mark.parametrize("name", ["bluerov2_alpha5", "amundsen2018"])
def test_the_compiled_hydrodynamic_terms_are_the_link_by_link_rnea_with_external_forces(name, rng):
    """Every term on (added mass in M and as C_A, damping with its forward-speed part, a current, buoyancy, a
    thrusters' wrench): the plant's Mbar and nbar equal the link-by-link derivation to rounding, at random states."""
    import dataclasses

    import pinocchio as pin

    robot = shipped(name)
    hydro = hydrodynamics_of(robot)
    forward = {link: dataclasses.replace(params, linear_damping_forward_speed=rng.uniform(0.0, 5.0, 6))
               for link, params in hydro.links.items()}  # uuv_simulator's forward-speed damping on every link
    plant = Plant(robot, dataclasses.replace(hydro, links=forward), gravity=True, current=[0.3, -0.2, 0.1])
    for _ in range(5):
        q = pin.integrate(robot.model, robot.neutral(), rng.normal(size=robot.nv))
        v, wrench = rng.normal(size=robot.nv), rng.normal(size=6) * 20.0
        mass, bias = plant._mass_and_bias(q, v, wrench)
        expected_mass, expected_bias = fossen_terms_link_by_link(plant, q, v, wrench)
        np.testing.assert_allclose(mass, expected_mass, rtol=1e-12, atol=1e-12 * np.abs(expected_mass).max())
        np.testing.assert_allclose(bias, expected_bias, rtol=1e-11, atol=1e-11 * np.abs(expected_bias).max())
        assert np.abs(bias - pin.rnea(robot.model, robot.model.createData(), q, v, np.zeros(robot.nv))).max() > 1.0


def test_the_plant_keeps_its_robots_base_placement_once(monkeypatch):
    """Plant.base_placement (the vehicle's root link in its joint's frame, read by the velocity loop's feedforward
    every step) is the robot's, kept once: not looked up and copied per read as Robot.base_placement is."""
    import pinocchio as pin

    robot = shipped("bluerov2_alpha5")
    placement = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.4, -0.1, 0.2]))
    monkeypatch.setattr(type(robot), "base_placement", property(lambda self: placement.copy()))
    plant = Plant(robot)
    assert plant.base_placement.isApprox(placement, 1e-15)
    assert plant.base_placement is plant.base_placement
