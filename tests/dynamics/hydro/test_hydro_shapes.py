"""uuv_simulator's shape models (uvms.dynamics.hydro.shapes) against their closed forms, each written here again
from the formula of HydrodynamicModel.cc (sphere, cylinder, box) or from Lamb's integrals by quadrature (spheroid).

Parsed from a URDF block, the values arrive in uvms's conventions: added mass (6, 6) in FLU and damping
coefficients >= 0 (the file's derivatives negated); a diagonal is the same in FRD and FLU.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from uvms.dynamics.hydro.hydrodynamics import parse_hydrodynamics
from uvms.errors import ModelCheckError, ShapeCoefficientWarning

RHO = 1000.0
PI = math.pi


def shape_urdf(model: str, link: str = "", mass: float = 10.0, rho: float = RHO) -> str:
    """One floating link 'body' with a uuv_simulator block: ``model`` inside <hydrodynamic_model>, ``link`` beside."""
    return f"""<robot name="body"><link name="world"/>
      <joint name="float" type="floating"><parent link="world"/><child link="body"/></joint>
      <link name="body"><inertial><mass value="{mass}"/>
        <inertia ixx="0.3" iyy="0.4" izz="0.5" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <gazebo><plugin name="uuv_plugin" filename="libuuv_underwater_object_ros_plugin.so">
        <fluid_density>{rho}</fluid_density>
        <link name="body"><volume>{mass / rho}</volume>{link}<hydrodynamic_model>{model}</hydrodynamic_model></link>
      </plugin></gazebo></robot>"""


def parsed(model: str, link: str = "", rho: float = RHO):
    return parse_hydrodynamics(shape_urdf(model, link, rho=rho), "shape.urdf").links["body"]


# ------------------------------------------------------------------ sphere
def test_a_sphere_has_two_thirds_rho_pi_r_cubed_on_each_translation_and_half_a_rho_cd_area_drag():
    r = 0.2
    link = parsed(f"<type>sphere</type><radius>{r}</radius>")
    np.testing.assert_allclose(link.added_mass, np.diag([2 / 3 * RHO * PI * r ** 3] * 3 + [0.0] * 3), rtol=1e-14)
    np.testing.assert_allclose(link.quadratic_damping, [0.5 * RHO * 0.5 * PI * r ** 2] * 3 + [0.0] * 3, rtol=1e-14)
    assert np.all(link.linear_damping == 0)
    assert 2 / 3 * RHO * PI * r ** 3 == pytest.approx(0.5 * RHO * 4 / 3 * PI * r ** 3)  # half the displaced mass


def test_a_shape_keeps_the_fossen_values_it_does_not_set():
    """A shape model is a fossen model whose diagonal entries it then sets (HMSphere derives from HMFossen)."""
    r = 0.1
    added = np.diag([9.0, 9.0, 9.0, 0.1, 0.2, 0.3])
    added[0, 4] = added[4, 0] = 0.05  # surge-pitch: flips sign FRD -> FLU
    link = parsed(f"<type>sphere</type><radius>{r}</radius><added_mass>{' '.join(map(str, added.ravel()))}"
                  "</added_mass><linear_damping>-1 -2 -3 -4 -5 -6</linear_damping>"
                  "<quadratic_damping>-7 -8 -9 -10 -11 -12</quadratic_damping>")
    sphere = 2 / 3 * RHO * PI * r ** 3
    np.testing.assert_allclose(np.diag(link.added_mass), [sphere] * 3 + [0.1, 0.2, 0.3], rtol=1e-14)
    assert link.added_mass[0, 4] == link.added_mass[4, 0] == -0.05
    np.testing.assert_array_equal(link.linear_damping, [1, 2, 3, 4, 5, 6])
    np.testing.assert_allclose(link.quadratic_damping, [0.25 * RHO * PI * r ** 2] * 3 + [10, 11, 12], rtol=1e-14)


# ------------------------------------------------------------------ cylinder
def cylinder_closed_form(r: float, length: float, axis: int, cd_circ: float, cd_len: float):
    """HMCylinder's diagonal, written out: (added mass (6,), quadratic coefficients (6,)), rotation about the
    axis left at 0."""
    added, quadratic = np.zeros(6), np.zeros(6)
    for i in range(3):
        if i == axis:
            added[i] = RHO * PI * r * r  # the source's entry along the axis (no length in it)
            quadratic[i] = 0.5 * cd_circ * PI * r * r * RHO
        else:
            added[i] = RHO * PI * r * r * length
            added[3 + i] = RHO * PI * r * r * length ** 3 / 12
            quadratic[i] = 0.5 * cd_len * r * length * RHO
    return added, quadratic


@pytest.mark.parametrize("axis", ["i", "j", "k"])
def test_a_cylinder_along_each_axis(axis):
    r, length = 0.05, 0.6  # L / 2r = 6: Cd 0.99 along the axis, 0.82 across
    link = parsed(f"<type>cylinder</type><radius>{r}</radius><length>{length}</length><axis>{axis}</axis>")
    added, quadratic = cylinder_closed_form(r, length, "ijk".index(axis), 0.99, 0.82)
    np.testing.assert_allclose(link.added_mass, np.diag(added), rtol=1e-14, atol=0)
    np.testing.assert_allclose(link.quadratic_damping, quadratic, rtol=1e-14, atol=0)


@pytest.mark.parametrize("ratio, cd_circ, cd_len", [
    (0.8, 0.91, 0.63), (1.0, 0.91, 0.63), (1.5, 0.85, 0.68), (2.0, 0.85, 0.68), (3.0, 0.87, 0.74),
    (4.0, 0.87, 0.74), (4.5, 0.99, 0.74), (5.0, 0.99, 0.74), (6.0, 0.99, 0.82), (7.0, 0.99, 0.82),
    (10.0, None, 0.82), (12.0, None, 0.98), (50.0, None, 0.98),
])
def test_the_cylinder_drag_coefficients_follow_the_table_of_the_source(ratio, cd_circ, cd_len, recwarn):
    r = 0.1
    model = f"<type>cylinder</type><radius>{r}</radius><length>{2 * r * ratio}</length><axis>k</axis>"
    if cd_circ is None:  # beyond the table (L / 2r > 7) the source leaves it undefined: its last value, warned
        with pytest.warns(ShapeCoefficientWarning, match=f"length / diameter {ratio:g} is beyond"):
            link = parsed(model)
        cd_circ = 0.99
    else:
        link = parsed(model)
        assert not [w for w in recwarn if issubclass(w.category, ShapeCoefficientWarning)]
    assert link.quadratic_damping[2] == pytest.approx(0.5 * cd_circ * PI * r * r * RHO, rel=1e-14)
    assert link.quadratic_damping[0] == pytest.approx(0.5 * cd_len * r * 2 * r * ratio * RHO, rel=1e-14)


def test_an_oberon7_link_takes_the_cylinder_from_its_box():
    """uuv_manipulators' Oberon7 writes <type>cylinder</type><axis>i</axis> and a <box> per link: the radius is the
    smallest extent, the length the largest (HMCylinder with the box of HydrodynamicModel's constructor)."""
    box = "<box><width>0.141889</width><length>0.616809</length><height>0.127829</height></box>"  # upper_arm
    link = parsed("<type>cylinder</type><axis>i</axis>", box)
    r, length = 0.127829, 0.616809  # L / 2r = 2.41: Cd 0.87 along, 0.74 across
    added, quadratic = cylinder_closed_form(r, length, 0, 0.87, 0.74)
    np.testing.assert_allclose(np.diag(link.added_mass), added, rtol=1e-14)
    np.testing.assert_allclose(link.quadratic_damping, quadratic, rtol=1e-14)
    without_axis = parsed("<type>cylinder</type>", box)  # the axis of the largest extent: y (the box's length)
    np.testing.assert_allclose(np.diag(without_axis.added_mass), cylinder_closed_form(r, length, 1, 0.87, 0.74)[0],
                               rtol=1e-14)
    sphere = parsed("<type>sphere</type>", box)  # the smallest extent as the radius, as the source does
    assert sphere.added_mass[0, 0] == pytest.approx(2 / 3 * RHO * PI * 0.127829 ** 3, rel=1e-14)


# ------------------------------------------------------------------ box
@pytest.mark.parametrize("cd", [None, 0.8])
def test_a_box_has_drag_on_the_area_facing_each_translation_and_no_added_mass(cd):
    length, width, height = 0.4, 0.3, 0.2
    tag = "" if cd is None else f"<cd>{cd}</cd>"
    link = parsed(f"<type>box</type><length>{length}</length><width>{width}</width><height>{height}</height>{tag}")
    c = 1.0 if cd is None else cd
    np.testing.assert_allclose(link.quadratic_damping, [0.5 * c * RHO * width * height, 0.5 * c * RHO * length *
                                                        height, 0.5 * c * RHO * width * length, 0, 0, 0], rtol=1e-14)
    assert np.all(link.added_mass == 0)


# ------------------------------------------------------------------ spheroid
@pytest.mark.parametrize("b, a", [(0.1, 0.5), (0.3, 0.31), (0.05, 1.0)])
def test_a_spheroid_has_lambs_added_mass(b, a):
    """Lamb's k-factors from his integrals alpha0 = a b^2 int dl / ((a^2 + l) D), beta0 = a b^2 int dl / ((b^2 + l) D),
    D = sqrt((a^2 + l) (b^2 + l)^2), by quadrature; rotation k' of the displaced fluid's moment of inertia."""
    link = parsed(f"<type>spheroid</type><radius>{b}</radius><length>{a}</length>")
    root = lambda lam: math.sqrt((a * a + lam) * (b * b + lam) ** 2)  # noqa: E731
    alpha = a * b * b * quad(lambda lam: 1 / ((a * a + lam) * root(lam)), 0, math.inf, epsabs=0, epsrel=1e-12)[0]
    beta = a * b * b * quad(lambda lam: 1 / ((b * b + lam) * root(lam)), 0, math.inf, epsabs=0, epsrel=1e-12)[0]
    e2 = 1 - (b / a) ** 2
    k_rotation = e2 ** 2 * (beta - alpha) / ((2 - e2) * (2 * e2 - (2 - e2) * (beta - alpha)))
    mass = RHO * 4 / 3 * PI * a * b * b
    inertia = mass * (a * a + b * b) / 5
    expected = [alpha / (2 - alpha) * mass, beta / (2 - beta) * mass, beta / (2 - beta) * mass, 0.0,
                k_rotation * inertia, k_rotation * inertia]
    np.testing.assert_allclose(np.diag(link.added_mass), expected, rtol=1e-8)
    assert np.all(link.quadratic_damping == 0) and np.min(np.diag(link.added_mass)[[0, 1, 4]]) > 0


# ------------------------------------------------------------------ what is refused
@pytest.mark.parametrize("model, link, message", [
    ("<type>sphere</type>", "", "the shape needs <radius> \\[m\\] in <hydrodynamic_model> \\(or a <box> of the link"),
    ("<type>cylinder</type><radius>0.1</radius><length>0.5</length>", "",
     "the cylinder has no <axis> \\(i, j or k\\) and the link no <box>"),
    ("<type>cylinder</type><radius>0.1</radius><length>0.5</length><axis>x</axis>", "",
     "axis must be i, j or k \\(x, y or z of the link\\), got 'x'"),
    ("<type>cylinder</type><radius>-0.1</radius><length>0.5</length><axis>i</axis>", "", "<radius> must be > 0 m"),
    ("<type>box</type><length>0.4</length><width>0.3</width>", "", "the box model needs <length>, <width> and "
                                                                    "<height> .* missing: height"),
    ("<type>box</type><length>0.4</length><width>0.3</width><height>0.2</height><cd>-1</cd>", "",
     "cd must be >= 0"),
    ("<type>spheroid</type><radius>0.5</radius><length>0.5</length>", "",
     "a spheroid needs radius \\(semi-minor axis\\) < length \\(semi-major axis\\)"),
    ("<type>sphere</type>", "<box><width>0.1</width><length>0.2</length></box>", "<box> misses height"),
])
def test_a_shape_without_what_it_needs_is_refused(model, link, message):
    with pytest.raises(ModelCheckError, match=f"shape.urdf: hydrodynamics of link 'body': .*{message}"):
        parsed(model, link)
