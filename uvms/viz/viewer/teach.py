"""Teach panel for notebooks: sliders for the vehicle pose and every one-DOF arm joint, the stick picture
and every end-effector pose (the panel of xiang2019's teaching interface).

:func:`teach_state` does the work (slider values -> q and end-effector poses) without widgets;
:func:`teach` wraps it in ipywidgets (optional: ``pip install uvms[viz]``).
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...errors import TeachUnavailable, UVMSError
from ...robot.bases import BASE_TYPES
from ...robot.configuration import Configuration
from ...robot.robot import Robot
from ..labels import joint_unit

INSTALL_HINT = "the teach panel needs ipywidgets: `pip install uvms[viz]`"
#: Slider names of the vehicle pose, by base type: position [m], then angles [rad].
VEHICLE_SLIDERS = {name: tuple(f"base_{axis}" for axis in base.pose_names) for name, base in BASE_TYPES.items()}
ANGLE_RANGES = {"base_roll": (-np.pi, np.pi), "base_pitch": (-np.pi / 2, np.pi / 2), "base_yaw": (-np.pi, np.pi)}


@dataclass(frozen=True)
class Slider:
    """One slider of the panel: a vehicle pose coordinate or a one-DOF arm joint.

    Attributes:
        name: ``base_x`` ... ``base_yaw`` or the joint name; lower, upper, value: range and start [m or rad].
        unit: "m" or "rad".
    """

    name: str
    lower: float
    upper: float
    value: float
    unit: str


def vehicle_pose_values(robot: Robot, q: np.ndarray) -> np.ndarray:
    """The vehicle pose of q as slider values: [x, y, yaw] (planar) or [x, y, z, roll, pitch, yaw] [m, rad]."""
    return robot.base_values(q)


def sliders(robot: Robot, q: np.ndarray | None = None, position_range: float = 5.0) -> list[Slider]:
    """The sliders for ``robot``, starting at configuration q (default neutral).

    Vehicle positions span [-r, r] with r = max(position_range, |start| + 1) [m]; roll and yaw
    [-pi, pi], pitch [-pi/2, pi/2]; a one-DOF arm joint spans its limits ([-pi, pi] when unbounded).
    Joints of several DOF keep their value from q and get no slider.
    """
    q = robot.neutral() if q is None else robot.check_configuration(q)
    result = []
    for name, value in zip(VEHICLE_SLIDERS[robot.base_type], vehicle_pose_values(robot, q)):
        if name in ANGLE_RANGES:
            lower, upper = ANGLE_RANGES[name]
            result.append(Slider(name, lower, upper, float(np.clip(value, lower, upper)), "rad"))
        else:
            reach = max(position_range, abs(float(value)) + 1.0)
            result.append(Slider(name, -reach, reach, float(value), "m"))
    for joint in robot.arm_joints:
        if joint.nv != 1:
            continue
        if joint.nq == 1:
            lower, upper, value = float(joint.lower[0]), float(joint.upper[0]), float(q[joint.idx_q])
        else:  # continuous joint stored as (cos, sin)
            lower, upper = -np.pi, np.pi
            value = float(np.arctan2(q[joint.idx_q + 1], q[joint.idx_q]))
        if not (np.isfinite(lower) and np.isfinite(upper)) or abs(lower) > 1e10 or abs(upper) > 1e10:
            lower, upper = -np.pi, np.pi
        result.append(Slider(joint.name, lower, upper, float(np.clip(value, lower, upper)), joint_unit(joint.kind)))
    return result


def teach_state(robot: Robot, values: Mapping[str, float], q: np.ndarray | None = None
                ) -> tuple[np.ndarray, dict[str, pin.SE3]]:
    """Configuration and end-effector poses for slider values.

    Args:
        robot: the robot.
        values: {slider name: value} [m, rad]; names from :func:`sliders` (``base_x``... and one-DOF
            arm joints). Missing names keep their value from q.
        q: the configuration the values modify (default neutral).

    Returns:
        (q (nq,), {end-effector frame: world pose}).

    Raises:
        UVMSError: an unknown name or a non-finite value (the message lists the valid names).
    """
    q = (robot.neutral() if q is None else robot.check_configuration(q)).copy()
    valid = [slider.name for slider in sliders(robot, q)]
    unknown = sorted(set(values) - set(valid))
    if unknown:
        raise UVMSError(f"unknown teach value(s) {', '.join(unknown)}; valid: {', '.join(valid)}")
    numbers = {}
    for name, value in values.items():
        try:
            numbers[name] = float(value)
        except (TypeError, ValueError):
            numbers[name] = float("nan")
        if not np.isfinite(numbers[name]):
            raise UVMSError(f"teach value {name!r} must be a finite number, got {value!r}")
    vehicle_names = VEHICLE_SLIDERS[robot.base_type]
    if vehicle_names and any(name in numbers for name in vehicle_names):
        pose = vehicle_pose_values(robot, q)
        pose = np.array([numbers.get(name, pose[k]) for k, name in enumerate(vehicle_names)])
        q[: robot.nq_vehicle] = robot.configuration(base=pose)[: robot.nq_vehicle]
    for joint in robot.arm_joints:
        if joint.name in numbers:
            value = numbers[joint.name]
            if joint.nq == 1:
                q[joint.idx_q] = value
            else:
                q[joint.idx_q: joint.idx_q + 2] = [np.cos(value), np.sin(value)]
    state = Configuration(robot, q)
    return q, {frame: state.pose(robot.frame_id(frame)).copy() for frame in robot.ee_frames}


def format_poses(poses: Mapping[str, pin.SE3]) -> str:
    """One line per frame: position [m] and roll, pitch, yaw [deg] in the world frame."""
    lines = []
    for frame, pose in poses.items():
        rpy = np.degrees(pin.rpy.matrixToRpy(pose.rotation))
        xyz = " ".join(f"{value:+.4f}" for value in pose.translation)
        angles = " ".join(f"{value:+8.2f}" for value in rpy)
        lines.append(f"{frame}: xyz [m] {xyz}   rpy [deg] {angles}")
    return "\n".join(lines)


def picture_png(robot: Robot, q: np.ndarray, plane: str | None, size: float = 5.0, dpi: int = 80) -> bytes:
    """The stick drawing of q as PNG bytes (headless, :func:`uvms.viz.drawing.draw_configuration`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..drawing import draw_configuration

    figure = Figure(figsize=(size, size))
    canvas = FigureCanvasAgg(figure)
    ax = figure.add_subplot(projection=None if plane else "3d")
    draw_configuration(ax, robot, q, plane=plane)
    ax.set_title(robot.name)
    figure.tight_layout()
    buffer = io.BytesIO()
    canvas.print_png(buffer)
    return buffer.getvalue()


def teach(robot: Robot, q: np.ndarray | None = None, *, plane: str | None = "auto",
          position_range: float = 5.0):
    """A teach panel: sliders, the stick picture and the end-effector poses, updated on every change.

    Args:
        robot: the robot.
        q: starting configuration (default neutral).
        plane: drawing plane ("xy", "xz", "yz"), None for 3-D, "auto": "xy" for a planar base, else 3-D.
        position_range: half range of the vehicle position sliders [m].

    Returns:
        An ``ipywidgets.VBox``; ``panel.sliders`` ({name: FloatSlider}), ``panel.picture`` (Image),
        ``panel.poses`` (HTML) and ``panel.state()`` -> (q, poses) are attached for scripting.

    Raises:
        TeachUnavailable: ipywidgets is not installed.
    """
    try:
        import ipywidgets as widgets
    except ImportError:
        raise TeachUnavailable(f"{INSTALL_HINT}; without widgets, "
                               "use uvms.viz.viewer.teach.teach_state(robot, values)") from None
    import html

    start = robot.neutral() if q is None else robot.check_configuration(q)
    if plane == "auto":
        plane = "xy" if robot.base_type == "planar" else None
    specs = sliders(robot, start, position_range)
    controls = {
        spec.name: widgets.FloatSlider(value=spec.value, min=spec.lower, max=spec.upper,
                                       step=(spec.upper - spec.lower) / 200, description=f"{spec.name} [{spec.unit}]",
                                       continuous_update=False, readout_format=".3f",
                                       style={"description_width": "initial"},
                                       layout=widgets.Layout(width="420px"))
        for spec in specs
    }
    picture = widgets.Image(format="png")
    poses_label = widgets.HTML()

    def state() -> tuple[np.ndarray, dict[str, pin.SE3]]:
        return teach_state(robot, {name: slider.value for name, slider in controls.items()}, start)

    def refresh(_change=None) -> None:
        configuration, poses = state()
        picture.value = picture_png(robot, configuration, plane)
        poses_label.value = f"<pre>{html.escape(format_poses(poses))}</pre>"

    for slider in controls.values():
        slider.observe(refresh, names="value")
    refresh()
    panel = widgets.VBox([widgets.HBox([widgets.VBox(list(controls.values())), picture]), poses_label])
    panel.sliders, panel.picture, panel.poses, panel.state = controls, picture, poses_label, state
    return panel
