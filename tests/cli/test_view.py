"""``uvms view`` options: ``--ee`` chooses the frames drawn with a triad; ``--headless`` draws a scenario's initial
configuration."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT, SCENARIOS, one_line
from uvms.cli import main
from uvms.scenario.build import build
from uvms.scenario.record import named_model
from uvms.scenario.schema import read_scenario
from uvms.viz import drawing

IDIOMS = ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf"


def test_ee_chooses_the_frames_a_model_is_drawn_with(tmp_path, capsys):
    assert named_model(str(IDIOMS)).ee_frames == ["arm_tool"]  # the rule
    assert named_model(str(IDIOMS), ee=["link3", "arm_tool"]).ee_frames == ["link3", "arm_tool"]
    assert main(["view", str(IDIOMS), "--ee", "link3", "--headless", str(tmp_path / "pose.png")]) == 0
    assert (tmp_path / "pose.png").stat().st_size > 10_000
    assert main(["view", str(IDIOMS), "--ee", "no_such_frame", "--headless", str(tmp_path / "x.png")]) == 2
    assert "no_such_frame" in one_line(capsys)
    assert main(["view", "--result", str(tmp_path), "--ee", "link3", "--headless", str(tmp_path / "y.png")]) == 2
    assert "drawn with the end effectors it was run with" in one_line(capsys)


def test_headless_view_of_a_scenario_draws_its_initial_configuration(tmp_path, monkeypatch):
    scenario = SCENARIOS / "bluerov2_alpha5_intervention.toml"
    drawn = {}

    def snapshot(robot, configurations, titles, **options):
        drawn.update(q=np.array(configurations[0]), title=titles[0], path=options["path"])

    monkeypatch.setattr(drawing, "snapshot_figure", snapshot)
    assert main(["view", str(scenario), "--headless", str(tmp_path / "start.png")]) == 0
    start = build(read_scenario(scenario)).q0  # what `uvms run` starts from
    robot = named_model(str(scenario))
    assert np.array_equal(drawn["q"], start) and not np.allclose(start, robot.neutral())
    assert robot.base_values(drawn["q"])[2] == pytest.approx(-5.0, abs=0.5)  # at depth, not at the surface
    assert drawn["title"] == "bluerov2_alpha5_intervention: initial configuration (bluerov2_alpha5)"
    hoang = SCENARIOS / "hoang2011_w1.toml"  # q0 optimized to put the end effector on the circle's start
    assert main(["view", str(hoang), "--headless", str(tmp_path / "h.png")]) == 0
    assert np.array_equal(drawn["q"], build(read_scenario(hoang)).q0)
    assert named_model(str(hoang)).fk(drawn["q"]).translation[:2] == pytest.approx([0.0, -2.0], abs=1e-6)
    assert main(["view", str(scenario), "--q", *["0"] * 5, "--headless", str(tmp_path / "q.png")]) == 0
    assert np.array_equal(drawn["q"], robot.configuration(arm=np.zeros(5)))  # --q wins
    assert main(["view", "bluerov2_alpha5", "--headless", str(tmp_path / "m.png")]) == 0
    assert np.array_equal(drawn["q"], robot.neutral()) and drawn["title"] == "bluerov2_alpha5"  # a model: neutral
