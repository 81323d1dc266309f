"""Scenarios: one TOML file names a model, a task, a trajectory and a solver; ``run`` computes it.

``schema`` (sections, keys, types, defaults, bounds; reading and ``--set`` overrides), ``build`` (model, task,
initial configuration, trajectory, controller, plant), ``runs`` (the one simulation loop of :mod:`uvms.simulate`,
metrics, the files of the run folder) and ``sweep`` (grids of overrides on joblib or Dask).

By default the motion is integrated kinematically. A ``[plant]`` section with ``type = "rigid"`` or
``"hydrodynamic"`` runs the free-floating dynamics of :mod:`uvms.dynamics.plant` instead, the joints driven by
the generalized-Jacobian controller of :mod:`uvms.control.gjm` (amundsen2018 eq. 4-8; the vehicle passive).
"""

from ..errors import ScenarioError
from .build import Setup, build
from .runs import RunResult, compute_metrics, run
from .schema import SCHEMA, name_from_stem, parse_value, read_scenario, read_toml, scenario_from_raw

__all__ = ["RunResult", "SCHEMA", "ScenarioError", "Setup", "build", "compute_metrics", "name_from_stem",
           "parse_value", "read_scenario", "read_toml", "run", "scenario_from_raw"]
