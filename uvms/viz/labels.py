"""Labels of figures that follow the model and the run: joint units from the joint's type, the vehicle's body
velocities by their FLU axis, solver methods by their full name, titles wrapped to the figure's width, text from a
file drawn as plain text."""

from __future__ import annotations

import textwrap

from ..robot.robot import Robot

#: Pinocchio short names (``model.joints[i].shortname()``) of the joints whose value is a length [m].
PRISMATIC_KINDS = frozenset({"JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"})

#: Characters of a 12-point title per inch of figure width (a wrapped title stays inside the figure).
TITLE_CHARACTERS_PER_INCH = 10.5

#: ``solver.method`` -> the name a reader knows the method by (legends of figures).
METHOD_NAMES = {
    "clik": "CLIK (weighted pseudo-inverse)",
    "task_priority": "task priority",
    "kinematic_constraint": "kinematic constraints (virtual chain)",
    "set_based": "set-based task priority (iCAT)",
    "hqp": "QP hierarchy",
}


def joint_unit(kind: str) -> str:
    """"m" for a prismatic joint (Pinocchio short name ``kind``, e.g. "JointModelPZ"), "rad" for any other."""
    return "m" if kind in PRISMATIC_KINDS else "rad"


def arm_joint_labels(robot: Robot, per_second: bool = False) -> list[str]:
    """One axis label per arm joint (n_arm,): "name [rad]" or "name [m]" (``per_second``: [rad/s] or [m/s])."""
    suffix = "/s" if per_second else ""
    return [f"{joint.name} [{joint_unit(joint.kind)}{suffix}]" for joint in robot.arm_joints]


def method_name(method: str) -> str:
    """The full name of a ``solver.method`` (:data:`METHOD_NAMES`); any other label as it is."""
    return METHOD_NAMES.get(method, method)


def figure_title(text: str, width: float) -> str:
    """``text`` wrapped to the width of a figure [in] (12-point characters), so that no line is cut off; its own
    line breaks are kept."""
    columns = int(width * TITLE_CHARACTERS_PER_INCH)
    return "\n".join(textwrap.fill(line, width=columns, break_on_hyphens=False) for line in text.split("\n"))


def plain_text(text: object) -> str:
    """``text`` (a scenario's name, a sampled string, a key...) as matplotlib draws it literally: every ``$``
    escaped, so that a stranger's string is never parsed as mathtext (``"$\\undefinedcmd{$"`` would make the
    whole figure fail)."""
    return str(text).replace("$", r"\$")
