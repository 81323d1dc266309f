"""The whole-body MPC as a scenario's controller (``[controller] type = "mpc"``).

On the actuated plant (``plant.type = "hydrodynamic"``, ``plant.thrusters = true``) the MPC
(:class:`uvms.control.mpc.controller.MPCController`) replaces the whole set-based chain: it predicts with the plant
(its current only with ``controller.knows_current``), follows the trajectory of ``task.frame``'s position, and keeps
the scenario's ``[[inequalities]]`` as the problem's constraints (CSQP) or penalties (Box-FDDP); the thrusters are
the model's, their bounds the inputs'. ``metrics.json`` gets its solve times and iterations
(:meth:`uvms.control.mpc.controller.MPCController.metrics`).
"""

from __future__ import annotations

import numpy as np

from ...dynamics.plant.actuated import ActuatedPlant
from ...dynamics.plant.command import State
from ...errors import ScenarioError, UVMSError
from ...tasks.frame import FrameTask
from ..actuated import Actuation
from ..inequalities import build_inequalities
from ..spec import ScenarioSpec
from .parts import Parts, Setup


def build_mpc(spec: ScenarioSpec, parts: Parts) -> Setup:
    """The MPC on the actuated plant (:func:`make_mpc_actuation`), its inequalities the problem's."""
    actuation = make_mpc_actuation(parts.actuated, parts.task, parts.trajectory, parts.q0, spec)
    return parts.setup(actuation.controller, inequalities=actuation.inequalities, actuation=actuation)


def make_mpc_actuation(actuated: ActuatedPlant, task: FrameTask, trajectory, q0: np.ndarray,
                       spec: ScenarioSpec) -> Actuation:
    """The thrusters of the model and the MPC of the scenario, compiled and warmed up at q0 (its first solve loads
    the derivative kernels, which is not a control step's time), then reset.

    Raises:
        ScenarioError: Crocoddyl missing (the message names ``pip install 'uvms[mpc]'``), a vehicle that is not
            floating, a ``[vehicle]`` task, the GJM controller's plant keys, fins; an objective or the MPC refusing.
    """
    from ...control.mpc.optional import require_crocoddyl, require_mim_solvers

    where, robot, thrusters, fins = "controller.type = 'mpc'", actuated.robot, actuated.thrusters, actuated.fins
    try:
        require_crocoddyl() if spec.controller.solver == "box_fddp" else require_mim_solvers()
    except UVMSError as exc:
        raise ScenarioError(f"{where}: {exc}") from None
    if robot.base_type != "floating":
        raise ScenarioError(f"{where} needs a floating vehicle; {robot.name} has a {robot.base_type} base")
    if spec.vehicle.changed():
        raise ScenarioError(f"{where}: the MPC holds the vehicle at its start by its posture costs "
                            f"(controller.vehicle_position, vehicle_attitude), not a [vehicle] task; remove [vehicle]")
    if spec.plant.motor_feedforward or spec.plant.control_dt:
        raise ScenarioError(f"{where}: plant.motor_feedforward and plant.control_dt are the GJM controller's; the "
                            f"MPC's period is controller.control_period")
    if len(fins):
        raise ScenarioError(f"{where}: {robot.name} has fins ({', '.join(fins.names)}), which the MPC does not "
                            f"command (it plans thrusts and arm commands); use controller.type = 'solver'")
    inequalities = None
    if spec.inequalities:  # the MPC's constraints: enforced, as CSQP's rows or Box-FDDP's penalties
        inequalities = build_inequalities(robot, spec.inequalities, enforced=True)
    from ...control.mpc.controller import MPCController

    try:
        controller = MPCController(actuated.plant, thrusters, lambda t: trajectory(t).pose.translation,
                                   frame=task.frame,
                                   settings=spec.controller.settings,
                                   constraints=inequalities.objectives if inequalities is not None else ())
        controller.reset(State(q0))
        controller.command(State(q0, np.zeros(robot.nv), np.zeros(len(thrusters))), 0.0)
        controller.reset(State(q0))
    except UVMSError as exc:
        raise ScenarioError(f"{where}: {exc}") from None
    return Actuation(actuated, controller, inequalities)
