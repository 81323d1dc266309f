"""uuv_simulator's shape models in the plant and in both file forms (uvms.dynamics.hydro.hydrodynamics), and the
per-link rows for ``uvms info`` (uvms.dynamics.hydro.parameters.hydro_rows)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_hydro_shapes import RHO, shape_urdf

import uvms
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of, parse_hydrodynamics
from uvms.dynamics.hydro.parameters import hydro_rows
from uvms.dynamics.plant.plant import Plant
from uvms.errors import AddedMassSymmetrizedWarning
from uvms.sim import simulate

PI = math.pi


def test_a_cylinder_coasts_along_its_axis_as_its_added_mass_and_drag_say():
    """(m + rho pi r^2) u' = -1/2 Cd rho pi r^2 u |u| (axis i, L / 2r = 3: Cd 0.87): u = u0 / (1 + k u0 t / M)."""
    r, length, mass, u0 = 0.1, 0.6, 10.0, 1.2
    robot = uvms.load(shape_urdf(f"<type>cylinder</type><radius>{r}</radius><length>{length}</length>"
                                 "<axis>i</axis>", mass=mass))
    result = simulate(Plant(robot, gravity=True), None, robot.neutral(), 2.0, 0.01, v0=[u0, 0, 0, 0, 0, 0])
    inertia, drag = mass + RHO * PI * r * r, 0.5 * 0.87 * RHO * PI * r * r
    np.testing.assert_allclose(result.v[:, 0], u0 / (1 + drag * u0 * result.t / inertia), rtol=1e-7, atol=0)
    assert result.v[-1, 0] < 0.6 * u0  # the drag is not small
    np.testing.assert_allclose(result.v[:, 1:], 0.0, atol=1e-12)
    sideways = simulate(Plant(robot), None, robot.neutral(), 0.5, 0.01, v0=[0, u0, 0, 0, 0, 0])
    across = mass + RHO * PI * r * r * length, 0.5 * 0.74 * RHO * r * length
    expected = u0 / (1 + across[1] * u0 * sideways.t / across[0])
    np.testing.assert_allclose(sideways.v[:, 1], expected, rtol=1e-7, atol=0)


def test_a_neutrally_buoyant_sphere_stays_at_rest_in_any_attitude():
    """<neutrally_buoyant> gives volume = m / rho; with the buoyancy at the centre of mass nothing moves it."""
    mass = 10.0
    urdf = shape_urdf("<type>sphere</type><radius>0.2</radius>", "<neutrally_buoyant>1</neutrally_buoyant>",
                      mass=mass).replace("<volume>0.01</volume>", "<volume>0.5</volume>")
    robot = uvms.load(urdf)
    hydro = hydrodynamics_of(robot)
    assert hydro.links["body"].volume == pytest.approx(mass / RHO, rel=1e-15)  # not the 0.5 m^3 written
    plant = Plant(robot, gravity=True)
    q0 = robot.configuration(base=[1.0, -2.0, -3.0, 0.4, -0.3, 1.2])
    assert np.abs(plant.acceleration(q0, np.zeros(6), np.zeros(0))).max() < 1e-12
    result = simulate(plant, None, q0, 5.0, 0.05)
    assert np.abs(result.v).max() < 1e-12 and np.abs(result.q - q0).max() < 1e-12
    assert np.ptp(result.plant.energy) < 1e-9


def test_volume_and_centre_of_buoyancy_are_read_for_every_model_type():
    for model in ("<type>fossen</type>", "<type>sphere</type><radius>0.1</radius>",
                  "<type>cylinder</type><radius>0.1</radius><length>0.5</length><axis>k</axis>",
                  "<type>spheroid</type><radius>0.1</radius><length>0.5</length>",
                  "<type>box</type><length>0.4</length><width>0.3</width><height>0.2</height>"):
        text = shape_urdf(model, "<center_of_buoyancy>0 0 0.03</center_of_buoyancy>").replace(
            "<volume>0.01</volume>", "<volume>0.012</volume>")
        link = parse_hydrodynamics(text, "shape.urdf").links["body"]
        assert link.volume == 0.012 and link.center_of_buoyancy.tolist() == [0.0, 0.0, 0.03], model


def test_the_fluid_density_of_the_block_is_the_shapes_density():
    r = 0.1
    for rho in (1000.0, 1028.0):
        link = parse_hydrodynamics(shape_urdf(f"<type>sphere</type><radius>{r}</radius>", rho=rho)).links["body"]
        assert link.added_mass[0, 0] == pytest.approx(2 / 3 * rho * PI * r ** 3, rel=1e-14)


def test_a_shapes_added_mass_is_symmetrised_like_a_fossen_one():
    added = np.diag([5.0, 5.0, 5.0, 0.2, 0.2, 0.2])
    added[3, 5], added[5, 3] = 0.01, 0.01 + 1e-7  # 2e-8 of the largest entry
    text = " ".join(map(str, added.ravel().tolist()))
    model = f"<type>sphere</type><radius>0.1</radius><added_mass>{text}</added_mass>"
    with pytest.warns(AddedMassSymmetrizedWarning, match="hydrodynamics of link 'body': added_mass is not exactly"):
        link = parse_hydrodynamics(shape_urdf(model), "shape.urdf").links["body"]
    assert link.added_mass[3, 5] == link.added_mass[5, 3] == pytest.approx(-0.01 - 5e-8, rel=1e-12)  # r flips


def test_a_yaml_takes_the_same_shape_keys(tmp_path):
    plain = shape_urdf("<type>fossen</type>")
    (tmp_path / "body.urdf").write_text(plain[:plain.index("<gazebo>")] + "</robot>")
    (tmp_path / "hydrodynamics.yaml").write_text(
        "fluid_density: 1000.0\nlinks:\n  body:\n    volume: 0.01\n"
        "    box: {width: 0.141889, length: 0.616809, height: 0.127829}\n"
        "    hydrodynamic_model: {type: cylinder, axis: i}\n")
    from_yaml = hydrodynamics_of(uvms.load(tmp_path / "body.urdf")).links["body"]
    box = "<box><width>0.141889</width><length>0.616809</length><height>0.127829</height></box>"
    from_urdf = parse_hydrodynamics(shape_urdf("<type>cylinder</type><axis>i</axis>", box)).links["body"]
    np.testing.assert_array_equal(from_yaml.added_mass, from_urdf.added_mass)
    np.testing.assert_array_equal(from_yaml.quadratic_damping, from_urdf.quadratic_damping)
    assert from_yaml.added_mass[1, 1] == pytest.approx(RHO * PI * 0.127829 ** 2 * 0.616809, rel=1e-14)


def test_hydro_rows_list_each_links_diagonals_volume_and_centre_of_buoyancy():
    r = 0.2
    text = shape_urdf(f"<type>sphere</type><radius>{r}</radius><linear_damping>-1 -2 -3 -4 -5 -6</linear_damping>",
                      "<center_of_buoyancy>0 0 0.05</center_of_buoyancy>")
    rows = hydro_rows(parse_hydrodynamics(text))
    assert len(rows) == 1 and rows[0]["link"] == "body"
    assert rows[0]["volume"] == pytest.approx(0.01) and rows[0]["center_of_buoyancy"] == [0.0, 0.0, 0.05]
    np.testing.assert_allclose(rows[0]["added_mass_diagonal"], [2 / 3 * RHO * PI * r ** 3] * 3 + [0] * 3, rtol=1e-14)
    assert rows[0]["linear_damping"] == [1, 2, 3, 4, 5, 6]
    np.testing.assert_allclose(rows[0]["quadratic_damping"], [0.25 * RHO * PI * r * r] * 3 + [0] * 3, rtol=1e-14)
    bluerov = hydro_rows(hydrodynamics_of(uvms.load("bluerov2_alpha5")))
    assert len(bluerov) > 1 and all(isinstance(value, (str, float, list)) for row in bluerov for value in row.values())


def test_linear_damping_forward_speed_is_applied_as_hmfossen_does(tmp_path):
    """uuv_simulator's HMFossen::ComputeDampingMatrix, in SNAME axes: D = -DLin - u DLinForwardSpeed
    - diag(DNonLin) |nu| (u = nu[0], signed), tau = -D nu; uvms's wrench in FLU is the same, at forward and backward
    speeds; ``uvms info`` and the YAML writer carry it."""
    from uvms.dynamics.hydro.hydrodynamics import load_hydrodynamics_yaml
    from uvms.dynamics.hydro.writer import hydrodynamics_yaml_text

    lin, forward = [-2.0, -3, -4, -0.5, -0.6, -0.7], [-1.5, -8.0, -9.0, 0.0, -2.5, -3.0]
    quad = [-10.0, -20, -30, -1, -2, -3]
    model = (f"<type>fossen</type><linear_damping>{' '.join(map(str, lin))}</linear_damping>"
             f"<linear_damping_forward_speed>{' '.join(map(str, forward))}</linear_damping_forward_speed>"
             f"<quadratic_damping>{' '.join(map(str, quad))}</quadratic_damping>")
    link = parse_hydrodynamics(shape_urdf(model), "auv.urdf").links["body"]
    flip = np.array([1.0, -1, -1, 1, -1, -1])  # FLU <-> SNAME (FRD)
    for nu in ([1.5, 0.2, -0.1, 0.05, 0.3, -0.2], [-0.8, -0.3, 0.4, -0.1, 0.2, 0.1]):
        ned = flip * np.array(nu)
        damping = -np.diag(lin) - ned[0] * np.diag(forward) - np.diag(quad) * np.abs(ned)
        np.testing.assert_allclose(link.damping_wrench(np.array(nu)), flip * (-damping @ ned), rtol=1e-13)
    row = hydro_rows(uvms.dynamics.HydroParameters(links={"body": link}))[0]
    assert row["linear_damping_forward_speed"] == [1.5, 8.0, 9.0, 0.0, 2.5, 3.0]
    path = tmp_path / "hydrodynamics.yaml"
    path.write_text(hydrodynamics_yaml_text(uvms.dynamics.HydroParameters(links={"body": link})))
    again = load_hydrodynamics_yaml(path).links["body"]
    np.testing.assert_allclose(again.linear_damping_forward_speed, link.linear_damping_forward_speed)
    with pytest.raises(uvms.errors.ModelCheckError, match="linear_damping_forward_speed holds positive values"):
        parse_hydrodynamics(shape_urdf(model.replace("-1.5 -8.0", "1.5 -8.0")), "auv.urdf")
