"""The hydrodynamics YAML writer (uvms.dynamics.hydro.writer): what it writes reads back as the same numbers."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of, load_hydrodynamics_yaml
from uvms.dynamics.hydro.parameters import LinkHydrodynamics
from uvms.dynamics.hydro.writer import hydrodynamics_yaml_text

from conftest import shipped


def test_the_models_hydrodynamics_round_trip_exactly(tmp_path):
    """The BlueROV2 + Alpha 5's (cylinder shapes, couplings off the diagonal) plus a link with a full M_A."""
    robot = shipped("bluerov2_alpha5")
    hydro = hydrodynamics_of(robot)
    coupled = np.diag([6.0, 7.0, 18.0, 0.2, 0.15, 0.25])
    coupled[0, 4] = coupled[4, 0] = 0.2  # surge-pitch
    coupled[1, 5] = coupled[5, 1] = -0.1  # sway-yaw
    hydro = replace(hydro, current=np.array([0.1, -0.2, 0.0]), links={
        **hydro.links, "base_link": LinkHydrodynamics(0.0121, [0.001, -0.002, 0.01], coupled,
                                                      linear_damping=[13.7, 0.0, 33.0, 0.0, 0.8, 0.0],
                                                      quadratic_damping=[141, 217, 190, 1.19, 0.47, 1.5])})
    path = tmp_path / "hydrodynamics.yaml"
    path.write_text(hydrodynamics_yaml_text(hydro, ["a comment"]))
    assert path.read_text().startswith("# a comment\n")
    back = hydrodynamics_of(robot, path)  # the loader's own checks, against the model's links
    assert list(back.links) == list(hydro.links)
    assert back.fluid_density == hydro.fluid_density and back.gravity == hydro.gravity
    np.testing.assert_array_equal(back.current, hydro.current)
    for name, link in hydro.links.items():
        for field in ("volume", "center_of_buoyancy", "added_mass", "linear_damping", "quadratic_damping"):
            np.testing.assert_array_equal(getattr(back.links[name], field), getattr(link, field), err_msg=field)


def test_the_file_is_in_the_uuv_simulator_conventions(tmp_path):
    """SNAME axes: the sway-yaw coupling keeps its sign (both flip), surge-sway flips; damping negative."""
    added = np.diag([6.0, 7.0, 18.0, 0.2, 0.15, 0.25])
    added[0, 1] = added[1, 0] = 0.3
    link = LinkHydrodynamics(0.01, [0.0, 0.0, 0.01], added, [1.0] * 6, [2.0] * 6)
    from uvms.dynamics.hydro.parameters import HydroParameters

    path = tmp_path / "h.yaml"
    path.write_text(hydrodynamics_yaml_text(HydroParameters(links={"base_link": link})))
    import yaml

    document = yaml.safe_load(path.read_text())
    model = document["links"]["base_link"]["hydrodynamic_model"]
    assert model["added_mass"][0][1] == -0.3 and model["linear_damping"] == [-1.0] * 6
    assert load_hydrodynamics_yaml(path).links["base_link"].added_mass[0, 1] == 0.3
