"""Scenarios: one TOML file names a model, a task, a trajectory and a solver; ``run`` computes it.

``resources`` (scenario files and the shipped scenarios by name), ``spec`` (the typed scenario: one frozen
dataclass per section, each key's type, default, allowed values, bound and meaning), ``schema`` (reading a file into
its spec, ``--set`` overrides), ``build`` (step count, model, start, plant, then the controller),
``controllers/`` (one builder module per kind of controller and ``CONTROLLERS``, their registry), ``runs`` (the
one simulation of :mod:`uvms.sim.loop`, metrics, the files of the run folder),
``verdict`` (joint limits kept, task error within tolerance), ``record`` (the model a run folder records, read
back by ``uvms view --result``); ``studies/`` (many runs: ``sweep``, grids of overrides; ``study``, Monte Carlo studies
with ``distributions``, ``sensitivity`` and their ``folder``; ``tune``, Optuna over scenario keys; all run by
``parallel``, joblib's loky or Dask); ``bags/`` (a run as a ROS 2 bag with its TF tree, ``writer``, ``tf_tree``; a bag
read back as a log for identification, ``reader``, ``limits``, ``thrust_log``).

By default the motion is integrated kinematically. A ``[plant]`` section with ``type = "rigid"`` or
``"hydrodynamic"`` runs the free-floating dynamics of :mod:`uvms.dynamics.plant.plant` instead, the joints driven by
the generalized-Jacobian controller of :mod:`uvms.control.gjm` (amundsen2018 eq. 4-8; the vehicle passive).
"""

from ..errors import ScenarioError
from .record import RunRecord, read_run_record
from .resources import resolve_scenario_path, shipped_scenarios
from .runs import RunResult, compute_metrics, run_scenario
from .schema import parse_value, read_scenario, read_toml, scenario_from_raw
from .spec import SECTIONS, ScenarioSpec

__all__ = ["RunRecord", "RunResult", "SECTIONS", "ScenarioError", "ScenarioSpec", "compute_metrics",
           "parse_value", "read_run_record", "read_scenario", "read_toml", "resolve_scenario_path", "run_scenario",
           "scenario_from_raw", "shipped_scenarios"]
