"""`uvms info` on every shipped model and on a URDF a user writes."""

from __future__ import annotations

import re

import pytest

from conftest import SHIPPED
from test_errors import FLOATING_ROOT, urdf
from uvms.cli import main


@pytest.mark.parametrize("name", SHIPPED)
def test_info_on_shipped_models(name, capsys):
    assert main(["info", name]) == 0
    out = capsys.readouterr().out
    assert "checks      passed" in out
    assert re.search(r"total mass  \d+\.\d{3} kg", out)


def test_info_on_a_user_urdf(tmp_path, capsys):
    path = tmp_path / "my_rov.urdf"
    path.write_text(urdf(root=FLOATING_ROOT))
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "floating: vehicle DOF 6, arm DOF 1" in out
    assert "total mass  2.000 kg" in out
    assert main(["info", str(path).replace("my_rov.urdf", "my_rov.urdf"), "--ee", "base_link"]) == 0


def test_info_xacro_args_change_the_model(capsys):
    assert main(["info", "hoang2011"]) == 0
    default = capsys.readouterr().out
    assert main(["info", "hoang2011", "--arg", "l1=1.0", "--arg", "vehicle_mass=200"]) == 0
    changed = capsys.readouterr().out
    assert "xyz [ 0.4 -1.7  0. ]" in default and "xyz [ 0.4 -2.3  0. ]" in changed
    assert "total mass  209.000 kg" in changed


def test_info_base_option_adds_a_vehicle(tmp_path, capsys):
    path = tmp_path / "arm.urdf"
    path.write_text(urdf())
    assert main(["info", str(path), "--base", "planar"]) == 0
    assert "planar: vehicle DOF 3, arm DOF 1" in capsys.readouterr().out
