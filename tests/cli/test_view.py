"""``uvms view`` options: ``--ee`` chooses the frames drawn with a triad; ``--headless`` draws a scenario's initial
configuration."""

from __future__ import annotations

import numpy as np
import pytest

from uvms.cli import main
from uvms.scenario.build import build
from uvms.scenario.record import named_model
from uvms.scenario.schema import read_scenario
from uvms.viz import drawing

from conftest import ROOT, SCENARIOS, one_line

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


def test_headless_writes_a_png_when_the_name_has_no_suffix(tmp_path, monkeypatch, capsys):
    """``--headless NAME`` writes NAME.png (before: a PNG named NAME); an unknown suffix is one line, exit 2 (before:
    an internal error of matplotlib's)."""
    armless = ROOT / "tests" / "fixtures" / "armless" / "vehicle.urdf"
    overlays = spy_overlays(monkeypatch)
    assert main(["view", str(armless), "--headless", str(tmp_path / "smilodon")]) == 0
    assert (tmp_path / "smilodon.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "smilodon").exists() and f"wrote {tmp_path / 'smilodon.png'}" in capsys.readouterr().out
    assert [len(mesh.triangles) for mesh in overlays[-1].visuals] == [12]  # the hull mesh drawn
    assert main(["view", str(armless), "--headless", str(tmp_path / "smilodon.foo")]) == 2
    message = one_line(capsys)
    assert "unknown suffix '.foo'" in message and ".png" in message and ".gif" in message
    assert not list(tmp_path.glob("smilodon.foo*"))


# ------------------------------------------------------------------ --collision, closest pairs
FOLD = ROOT / "tests" / "fixtures" / "collision" / "box_arm_fold.toml"


def spy_overlays(monkeypatch) -> list:
    """The overlays ``uvms view`` hands to the drawing (the drawing itself still runs)."""
    overlays = []
    for name in ("snapshot_figure", "animate"):
        original = getattr(drawing, name)

        def spy(*args, original=original, **options):
            overlays.append(options.get("overlay"))
            return original(*args, **options)

        monkeypatch.setattr(drawing, name, spy)
    return overlays


def test_collision_draws_the_shapes_and_a_scenarios_closest_pairs(tmp_path, monkeypatch, capsys):
    from uvms.model.collision import collision_geometry

    overlays = spy_overlays(monkeypatch)
    assert main(["view", "--collision", str(FOLD), "--headless", str(tmp_path / "shapes.png")]) == 0
    assert (tmp_path / "shapes.png").stat().st_size > 10_000
    [overlay] = overlays
    assert len(overlay.meshes) == collision_geometry(overlay.robot).ngeoms
    assert [objective.name for objective in overlay.closest.objectives] == ["self_collision", "obstacle(mesh)"]
    assert len(overlay.obstacles) == 1  # the rock
    assert main(["view", str(FOLD), "--headless", str(tmp_path / "plain.png")]) == 0
    plain = overlays[-1]  # no toggle, no run: the visual meshes, no collision shapes nor pairs
    assert plain.meshes == [] and not plain.closest.objectives and not plain.obstacles


def test_a_runs_replay_marks_the_closest_pairs_of_its_collision_objectives(tmp_path, monkeypatch, capsys):
    run = tmp_path / "run"
    assert main(["run", str(FOLD), "--out", str(run), "--quiet", "--set", "simulation.duration=0.2"]) == 0
    capsys.readouterr()
    overlays = spy_overlays(monkeypatch)
    assert main(["view", str(FOLD), "--result", str(run), "--headless", str(tmp_path / "run.png")]) == 0
    assert [item.name for item in overlays[-1].closest.objectives] == ["self_collision", "obstacle(mesh)"]
    assert overlays[-1].meshes == []  # marks without --collision
    assert main(["view", "--result", str(run), "--collision", "--headless", str(tmp_path / "run.gif"),
                 "--frames", "3"]) == 0
    assert "not in its folder" in capsys.readouterr().out  # no scenario: the model's own self-collision pairs
    [objective] = overlays[-1].closest.objectives
    assert objective.name == "self_collision" and objective.min == 0.01 and overlays[-1].meshes
