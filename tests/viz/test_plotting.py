"""Figures of a run (uvms.viz.plotting): the path and the desired motion follow the task's axes (3-D, a plane,
the planar vehicle's x-y)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import NO_FIGURES
from uvms.scenario import run_scenario
from uvms.viz.plotting import desired_motion_figure, path_figure


def yz_circle(tmp_path: Path, axes: list[str]) -> Path:
    """A 5 cm circle in the y-z plane of the world, driven by the bluerov2_alpha5 end effector."""
    path = tmp_path / f"yz_{''.join(axes)}.toml"
    path.write_text(f"""
[model]
path = "bluerov2_alpha5"
[task]
axes = {json.dumps(axes)}
[trajectory]
type = "circle"
center_offset = [0.0, 0.0, 0.05]
normal = [1.0, 0.0, 0.0]
law = "quintic"
duration = 4.0
[initial]
arm = [3.0, 1.5, 1.5, 3.0, 0.005]
[solver]
gain = 5.0
[simulation]
dt = 0.02
""")
    return path


def ylabels(figure) -> list[str]:
    return [axis.get_ylabel() for axis in figure.axes]


def test_a_circle_in_the_y_z_plane_is_drawn_in_3d_when_the_task_is_3d(tmp_path):
    result = run_scenario(yz_circle(tmp_path, ["x", "y", "z"]), out=tmp_path / "yz3", progress=False)
    assert result.metrics["max_position_error"] < 1e-6
    assert np.ptp(result.simulation.desired_position[:, 2]) == pytest.approx(0.1, rel=1e-6)  # it moves in z
    path = path_figure(result.simulation, "yz")
    (axis,) = path.axes
    assert axis.name == "3d"
    assert (axis.get_xlabel(), axis.get_ylabel(), axis.get_zlabel()) == ("x [m]", "y [m]", "z [m]")
    assert "3-D" in axis.get_title()
    desired = desired_motion_figure(result.simulation, result.setup.trajectory, "yz")
    assert ylabels(desired) == ["speed [m/s]", "x_d [m]", "y_d [m]", "z_d [m]"]  # z was missing before
    assert np.ptp(desired.axes[3].lines[0].get_ydata()) == pytest.approx(0.1, rel=1e-6)
    for name in ("path.png", "desired_motion.png"):
        assert (tmp_path / "yz3" / name).stat().st_size > 10_000


def test_a_planar_task_is_drawn_in_its_own_plane(tmp_path):
    result = run_scenario(yz_circle(tmp_path, ["y", "z"]), out=tmp_path / "yz2", progress=False, overrides=NO_FIGURES)
    (axis,) = path_figure(result.simulation, "yz").axes
    assert axis.name != "3d"
    assert (axis.get_xlabel(), axis.get_ylabel()) == ("y [m]", "z [m]")
    assert "the y-z plane" in axis.get_title()
    desired = desired_motion_figure(result.simulation, result.setup.trajectory, "yz")
    assert ylabels(desired) == ["speed [m/s]", "y_d [m]", "z_d [m]"]
    # a planar vehicle's x, y, yaw task keeps its x-y figure
    hoang = run_scenario("hoang2011_w1_euler", out=tmp_path / "h", progress=False,
                overrides=[*NO_FIGURES, "simulation.duration=2"])
    (axis,) = path_figure(hoang.simulation, "h").axes
    assert (axis.get_xlabel(), axis.get_ylabel(), axis.get_title()) == ("x [m]", "y [m]", "h: paths in the x-y plane")
    assert ylabels(desired_motion_figure(hoang.simulation, hoang.setup.trajectory)) == [
        "speed [m/s]", "x_d [m]", "y_d [m]", "yaw_d [rad]"]
