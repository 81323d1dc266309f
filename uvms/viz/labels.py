"""Labels of figures that follow the model and the run: joint units from the joint's type, the vehicle's body
velocities by their FLU axis, solver methods by their full name, titles wrapped to the figure's width, legends
below the axes (clear of the data), text from a file drawn as plain text."""

from __future__ import annotations

import textwrap

from matplotlib.legend_handler import HandlerTuple
from matplotlib.transforms import ScaledTranslation

from ..robot.robot import Robot

#: Pinocchio short names (``model.joints[i].shortname()``) of the joints whose value is a length [m].
PRISMATIC_KINDS = frozenset({"JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"})

#: Characters of a 12-point title per inch of figure width (a wrapped title stays inside the figure).
TITLE_CHARACTERS_PER_INCH = 10.5

#: [in] How far below its Axes :func:`legend_under` hangs a legend (under 10-point tick and axis labels).
LEGEND_DROP = 0.45

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


def legend_below(figure, entries, columns: int = 3, fontsize: float = 8):
    """A figure legend centred below every Axes, clear of the data.

    Args:
        figure: the figure. With a constrained layout its Axes shrink to make room for the legend; without one the
            caller leaves room at the bottom (``subplots_adjust(bottom=...)``, ``tight_layout(rect=...)``).
        entries: (handle, label) pairs; a handle may be a tuple of artists, drawn side by side (e.g. the x, y, z
            axes of a triad in red, green, blue).
        columns: at most this many entries a row: fewer when the rows would be wider than the figure.
        fontsize: of the labels [pt].
    """
    handles, labels = zip(*entries) if entries else ((), ())
    while True:
        legend = figure.legend(list(handles), list(labels), loc="outside lower center", ncol=columns,
                               fontsize=fontsize, handlelength=2.5,
                               handler_map={tuple: HandlerTuple(ndivide=None, pad=0.2)})
        if columns == 1 or legend.get_window_extent().width <= 0.98 * figure.bbox.width:
            return legend
        legend.remove()  # its rows are laid out when it is made: made again with fewer columns
        columns -= 1


def legend_under(ax, handles, labels, fontsize: float = 7, drop: float = LEGEND_DROP):
    """A legend of one Axes hung below it, under its tick and axis labels (clear of the data): ``drop`` [in] below
    the Axes' bottom edge. A constrained or tight layout makes room for it."""
    offset = ScaledTranslation(0.0, -drop, ax.figure.dpi_scale_trans)
    return ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0),
                     bbox_transform=ax.transAxes + offset, fontsize=fontsize)


def plain_text(text: object) -> str:
    """``text`` (a scenario's name, a sampled string, a key...) as matplotlib draws it literally: every ``$``
    escaped, so that a stranger's string is never parsed as mathtext (``"$\\undefinedcmd{$"`` would make the
    whole figure fail)."""
    return str(text).replace("$", r"\$")
