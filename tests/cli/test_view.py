"""``uvms view`` options: ``--ee`` chooses the frames drawn with a triad."""

from __future__ import annotations

from conftest import ROOT, one_line
from uvms.cli import main
from uvms.scenario.record import named_model

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
