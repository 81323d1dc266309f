"""The vehicle's equations of motion as a regression linear in its hydrodynamic parameters.

The vehicle rows of the plant (:func:`uvms.dynamics.plant.actuated.vehicle_inverse_dynamics`, Fossen's
M_RB nu' + M_A nu_r' + C(nu) nu + C_A(nu_r) nu_r + D(nu_r) nu_r + g(eta) = tau for the whole UVMS) split into

    tau - known(q, v, a) = Phi(q, v, a) theta

* ``known``: everything Pinocchio computes from the URDF (rigid-body inertia and Coriolis of the vehicle *and*
  the arm, the weight of every link, so the arm's reaction on a moving arm) plus the hydrodynamics of every
  other link (the arm's, from the model): the same plant with the identified link's parameters removed;
* ``Phi theta``: the identified link's (the vehicle's root link, whose frame is the body frame of the twist
  and the wrench) added-mass inertia and Coriolis M_A nu_r' + C_A(nu_r) nu_r, damping
  (D_l + D_q |nu_r|) nu_r and buoyancy -[rho g V R^T e_z; rho g s x R^T e_z], s = V r_B its first moment.

Parameters (uvms's FLU axes, [u v w p q r] about the link origin, as :class:`LinkHydrodynamics` holds them):
added mass (the 6 diagonal entries, or the 21 of the upper triangle of a full symmetric M_A), linear and
quadratic damping coefficients (6 each, >= 0), the volume V [m^3] and the buoyancy moment s = V r_B (3,)
[m^4] (r_B = s / V, the centre of buoyancy). nu_r = nu - [R^T v_c; 0] with a known constant current v_c.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from ...errors import IdentificationError
from ..hydro.parameters import HydroParameters, LinkHydrodynamics
from ..plant.actuated import base_twist, vehicle_inverse_dynamics
from ..plant.plant import Plant
from .data import SmoothedStates

#: The body axes, FLU, in the order of the twist and wrench.
AXES = ("u", "v", "w", "p", "q", "r")
#: The forms of the added mass that can be identified.
ADDED_MASS_FORMS = ("diagonal", "full")


@dataclass(frozen=True)
class ParameterLayout:
    """The identified parameters: names, units, kinds, prior values and scales, in the order of theta.

    Attributes:
        names: e.g. "added_mass[u]", "added_mass[u,q]", "linear_damping[w]", "volume", "buoyancy_moment[z]".
        kinds: "added_mass", "linear_damping", "quadratic_damping", "volume", "buoyancy_moment" per parameter.
        units: SI units per parameter.
        prior: (p,) the model's values; scale: (p,) typical magnitudes (identifiability, conditioning).
        pairs: the (i, j) entry of M_A of each added-mass parameter, i <= j.
        form: "diagonal" or "full".
    """

    names: tuple[str, ...]
    kinds: tuple[str, ...]
    units: tuple[str, ...]
    prior: np.ndarray
    scale: np.ndarray
    pairs: tuple[tuple[int, int], ...]
    form: str

    def indices(self, kind: str) -> np.ndarray:
        """The positions of the parameters of one kind."""
        return np.array([k for k, name in enumerate(self.kinds) if name == kind], dtype=int)


def _added_mass_unit(i: int, j: int) -> str:
    return {0: "kg", 1: "kg m", 2: "kg m^2"}[(i >= 3) + (j >= 3)]


def parameter_layout(link: LinkHydrodynamics, rigid_mass: np.ndarray, form: str = "diagonal") -> ParameterLayout:
    """The parameters of ``link`` to identify, with its values as the prior.

    Scales (what a parameter's standard error is compared with): the prior's magnitude, at least a floor made
    from the vehicle's rigid-body mass matrix M_RB (6, 6) (arm included): 10 % of M_RB,ii for an added mass
    (sqrt(M_ii M_jj) for a coupling), M_RB,ii / (10 s) for a linear damping (a 10 s time constant),
    M_RB,ii / (10 s x 1 m/s or rad/s) for a quadratic one, 1 cm times the volume for the buoyancy moment.

    Raises:
        IdentificationError: an unknown form.
    """
    if form not in ADDED_MASS_FORMS:
        raise IdentificationError(f"unknown added-mass form {form!r}; valid: {', '.join(ADDED_MASS_FORMS)}")
    mass = np.abs(np.diag(rigid_mass))
    pairs = tuple((i, i) for i in range(6)) if form == "diagonal" else \
        tuple((i, j) for i in range(6) for j in range(i, 6))
    names, kinds, units, prior, floor = [], [], [], [], []
    for i, j in pairs:
        names.append(f"added_mass[{AXES[i]}]" if i == j else f"added_mass[{AXES[i]},{AXES[j]}]")
        kinds.append("added_mass")
        units.append(_added_mass_unit(i, j))
        prior.append(link.added_mass[i, j])
        floor.append(0.1 * np.sqrt(mass[i] * mass[j]))
    for kind, values, unit_pair, time in (("linear_damping", link.linear_damping, ("N s/m", "N m s/rad"), 10.0),
                                          ("quadratic_damping", link.quadratic_damping,
                                           ("N s^2/m^2", "N m s^2/rad^2"), 10.0)):
        for i in range(6):
            names.append(f"{kind}[{AXES[i]}]")
            kinds.append(kind)
            units.append(unit_pair[i >= 3])
            prior.append(values[i])
            floor.append(mass[i] / time)
    volume = link.volume
    names.append("volume")
    kinds.append("volume")
    units.append("m^3")
    prior.append(volume)
    floor.append(max(volume, 1e-6))
    for axis, value in zip("xyz", volume * link.center_of_buoyancy):
        names.append(f"buoyancy_moment[{axis}]")
        kinds.append("buoyancy_moment")
        units.append("m^4")
        prior.append(value)
        floor.append(0.01 * max(volume, 1e-6))
    prior_array = np.array(prior, dtype=float) + 0.0  # + 0.0: no -0.0 (a file's 0 damping, negated)
    return ParameterLayout(tuple(names), tuple(kinds), tuple(units), prior_array,
                           np.maximum(np.abs(prior_array), np.array(floor)), pairs, form)


def added_mass_matrix(layout: ParameterLayout, theta: np.ndarray) -> np.ndarray:
    """M_A (6, 6) from the added-mass entries of theta; entries outside the layout are zero."""
    matrix = np.zeros((6, 6))
    for value, (i, j) in zip(theta[layout.indices("added_mass")], layout.pairs):
        matrix[i, j] = matrix[j, i] = value
    return matrix


def link_from_theta(layout: ParameterLayout, theta: np.ndarray, prior: LinkHydrodynamics) -> LinkHydrodynamics:
    """The identified link's LinkHydrodynamics (the prior's off-diagonal added mass kept in the diagonal form).

    Raises:
        ModelCheckError: values that are not physical (negative damping, an indefinite M_A, V < 0).
    """
    added = added_mass_matrix(layout, theta)
    if layout.form == "diagonal":
        added = prior.added_mass - np.diag(np.diag(prior.added_mass)) + added
    volume = float(theta[layout.indices("volume")][0])
    moment = theta[layout.indices("buoyancy_moment")]
    return LinkHydrodynamics(volume=volume, center_of_buoyancy=moment / volume if volume > 0 else np.zeros(3),
                             added_mass=added, linear_damping=theta[layout.indices("linear_damping")],
                             quadratic_damping=theta[layout.indices("quadratic_damping")])


# ------------------------------------------------------------------ the plant of the known terms
def identified_link_name(robot, hydro: HydroParameters) -> str:
    """The vehicle's root link, which must carry hydrodynamic parameters in ``hydro``.

    Raises:
        IdentificationError: a planar or fixed base, or no parameters on the root link.
    """
    if robot.base_type != "floating":
        raise IdentificationError(f"{robot.name} has a {robot.base_type} base; identification needs a floating "
                                  "vehicle (6 body axes)")
    name = robot.root_link
    if name not in hydro.links:
        raise IdentificationError(f"{hydro.source}: the vehicle's root link {name!r} has no hydrodynamic parameters "
                                  f"to start from (links with some: {', '.join(hydro.links) or 'none'}); add "
                                  "them (any values: they are the prior) to the model or its hydrodynamics.yaml")
    return name


def known_plant(robot, hydro: HydroParameters, link: str, current: np.ndarray) -> Plant:
    """The plant with gravity, the known current and every link's hydrodynamics but ``link``'s."""
    others = {name: params for name, params in hydro.links.items() if name != link}
    return Plant(robot, replace(hydro, links=others), gravity=True, current=current)


def configurations(robot, states: SmoothedStates) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q (K, nq), v (K, nv) and a (K, nv) of the smoothed log (the root link's pose and twist moved to the
    vehicle joint, which carries the link at a fixed placement)."""
    model = robot.model
    placement = model.frames[model.getFrameId(robot.root_link, pin.FrameType.BODY)].placement
    count = len(states.t)
    q = np.zeros((count, model.nq))
    for k in range(count):
        link_pose = pin.XYZQUATToSE3(np.concatenate([states.position[k], states.quaternion[k]]))
        q[k, :7] = pin.SE3ToXYZQUAT(link_pose * placement.inverse())
    q[:, 7:] = states.joint_position
    joint = np.array([placement.act(pin.Motion(row)).vector for row in states.twist])
    joint_rate = np.array([placement.act(pin.Motion(row)).vector for row in states.twist_rate])
    return q, np.hstack([joint, states.joint_velocity]), np.hstack([joint_rate, states.joint_acceleration])


@dataclass(frozen=True)
class Regression:
    """tau - known = Phi theta over the samples of a smoothed log.

    Attributes:
        target: (K, 6) the wrench minus the known terms [N, N m]; regressor: (K, 6, p) Phi.
        q, v, a: (K, nq), (K, nv), (K, nv) the states (held-out prediction starts from them).
        vehicle_mass: (6, 6) the known plant's Mbar_bb (rigid + the arm's added mass), mean over the log: what
            multiplies the base acceleration in the known terms.
        rate_noise: (6,) the variance of the noise of the base acceleration (``SmoothedStates.twist_rate_noise``).
    """

    target: np.ndarray
    regressor: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    vehicle_mass: np.ndarray
    rate_noise: np.ndarray


def regression(plant: Plant, layout: ParameterLayout, states: SmoothedStates) -> Regression:
    """The regression of a smoothed log (module docstring), the known terms from ``plant`` (:func:`known_plant`)."""
    robot = plant.robot
    q, v, a = configurations(robot, states)
    nb = plant.nb
    known = np.array([vehicle_inverse_dynamics(plant, q[k], v[k], a[k, :nb], a[k, nb:]) for k in range(len(q))])
    nu = np.array([base_twist(plant, row) for row in v])
    nu_rate = np.array([base_twist(plant, row) for row in a])
    rotation = np.array([pin.Quaternion(np.asarray(row)).toRotationMatrix() for row in states.quaternion])
    current = np.einsum("kji,j->ki", rotation, plant.hydro.current)  # R^T v_c per sample
    nu_r = nu.copy()
    nu_r[:, :3] -= current
    nu_r_rate = nu_rate.copy()
    nu_r_rate[:, :3] += np.cross(nu[:, 3:], current)  # nu_c' = [-w x R^T v_c; 0]
    up = rotation[:, 2, :]  # R^T e_z per sample
    columns = []
    for i, j in layout.pairs:
        basis = np.zeros((6, 6))
        basis[i, j] = basis[j, i] = 1.0
        columns.append(nu_r_rate @ basis.T + _coriolis(nu_r @ basis.T, nu_r))
    for kind in ("linear_damping", "quadratic_damping"):
        for i in range(6):
            column = np.zeros((len(q), 6))
            column[:, i] = nu_r[:, i] * (1.0 if kind == "linear_damping" else np.abs(nu_r[:, i]))
            columns.append(column)
    weight = plant.hydro.fluid_density * plant.hydro.gravity
    columns.append(np.hstack([-weight * up, np.zeros((len(q), 3))]))
    for axis in np.eye(3):
        columns.append(np.hstack([np.zeros((len(q), 3)), -weight * np.cross(axis, up)]))
    vehicle_mass = np.mean([plant.mass_matrix(row)[:nb, :nb] for row in q[::10]], axis=0)
    return Regression(states.wrench - known, np.stack(columns, axis=2), q, v, a, vehicle_mass,
                      states.twist_rate_noise)


def acceleration_noise_terms(layout: ParameterLayout, weights: np.ndarray,
                             data: Regression) -> tuple[np.ndarray, np.ndarray]:
    """The expected share of the base acceleration's noise n in the normal equations, per sample (errors in
    variables: bias-compensated least squares).

    With nu_r' = true + n, E[n n^T] = Sigma = diag(``data.rate_noise``), the added-mass columns carry E_k n and the
    target carries -Mbar_bb n (the known terms); on the scaled, weighted normal equations (W = diag(weights))
    E[a^T a] gains P_kl = s_k s_l tr(E_k W^2 E_l Sigma) and E[a^T b] loses m_k = s_k tr(E_k W^2 Mbar_bb Sigma)
    per sample, which the fit adds back (P (p, p), m (p,), zero outside the added mass).
    """
    count = len(layout.scale)
    sigma = np.diag(data.rate_noise)
    weight = np.diag(weights ** 2)
    added = layout.indices("added_mass")
    bases = []
    for i, j in layout.pairs:
        basis = np.zeros((6, 6))
        basis[i, j] = basis[j, i] = 1.0
        bases.append(basis)
    gram, moment = np.zeros((count, count)), np.zeros(count)
    for row, (k, left) in enumerate(zip(added, bases)):
        moment[k] = layout.scale[k] * np.trace(left @ weight @ data.vehicle_mass @ sigma)
        for m, right in zip(added, bases):
            gram[k, m] = layout.scale[k] * layout.scale[m] * np.trace(left @ weight @ right @ sigma)
    return gram, moment


def _coriolis(momentum: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """C_A(nu) nu = [w x a1; v x a1 + w x a2] (K, 6) for a = M_A nu (K, 6) (Fossen 2011, eq. 6.43)."""
    linear, angular = nu[:, :3], nu[:, 3:]
    return np.hstack([np.cross(angular, momentum[:, :3]),
                      np.cross(linear, momentum[:, :3]) + np.cross(angular, momentum[:, 3:])])


def rigid_vehicle_mass(plant: Plant, q: np.ndarray) -> np.ndarray:
    """M_RB (6, 6) of the vehicle rows at q, the arm's inertia included (Pinocchio's crba)."""
    mass = pin.crba(plant.model, plant.model.createData(), q)
    mass = np.triu(mass) + np.triu(mass, 1).T
    return mass[:plant.nb, :plant.nb]
