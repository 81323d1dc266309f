"""Whether a run did what its scenario asked: inside the joint limits, task error within the stated tolerance.

The numbers are those of ``metrics.json``; the tolerances are ``[outputs] position_tolerance`` [m] and
``orientation_tolerance`` [rad] of the scenario (defaults in :mod:`uvms.scenario.schema`). ``uvms run`` prints
each problem as a warning line; ``metrics.json`` records the verdict under ``"verdict"``.
"""

from __future__ import annotations

from collections.abc import Sequence

from .spec import OutputsSpec

#: Joint-limit violations up to this size [rad or m] are rounding of the integrator, not a violation (xiang2019's
#: grip sequence ends 3.4e-11 rad past a limit it is steered onto).
LIMIT_SLACK = 1e-9


def run_verdict(metrics: dict, outputs: OutputsSpec, objective_warnings: Sequence[str] = ()) -> dict:
    """The verdict of a run from its metrics and the scenario's ``[outputs]`` tolerances.

    Args:
        metrics: at least ``max_joint_limit_violation`` [rad or m], ``max_position_error`` [m] and
            ``max_orientation_error`` [rad].
        outputs: the scenario's ``[outputs]`` (``position_tolerance`` [m], ``orientation_tolerance`` [rad]).
        objective_warnings: sentences about ``[[inequalities]]`` left (:mod:`uvms.scenario.inequalities`).

    Returns:
        ``{"ok", "within_joint_limits", "within_tolerance", "position_tolerance", "orientation_tolerance",
        "joint_limit_slack", "warnings"}``: booleans, the tolerances used, and one sentence per problem.
    """
    position_tolerance = float(outputs.position_tolerance)
    orientation_tolerance = float(outputs.orientation_tolerance)
    violation = float(metrics["max_joint_limit_violation"])
    position, orientation = float(metrics["max_position_error"]), float(metrics["max_orientation_error"])
    warnings = []
    inside = violation <= LIMIT_SLACK
    if not inside:
        warnings.append(f"the arm left its joint limits by up to {violation:.3g} rad or m "
                        f"(max_joint_limit_violation); an [[inequalities]] table of type 'joint_limits' with "
                        f"solver.method = 'set_based' or 'hqp' keeps them (with clik: solver.enforce_limits = true "
                        f"holds the joints at their limits, solver.alpha > 0 steers them away)")
    position_ok, orientation_ok = position <= position_tolerance, orientation <= orientation_tolerance
    if not position_ok:
        warnings.append(f"the position error reached {position:.3g} m (max_position_error), above "
                        f"outputs.position_tolerance = {position_tolerance:g} m")
    if not orientation_ok:
        warnings.append(f"the orientation error reached {orientation:.3g} rad (max_orientation_error), above "
                        f"outputs.orientation_tolerance = {orientation_tolerance:g} rad")
    warnings.extend(objective_warnings)
    return {
        "ok": not warnings,
        "within_joint_limits": inside,
        "within_inequalities": not objective_warnings,
        "within_tolerance": position_ok and orientation_ok,
        "position_tolerance": position_tolerance,
        "orientation_tolerance": orientation_tolerance,
        "joint_limit_slack": LIMIT_SLACK,
        "warnings": warnings,
    }


def verdict_line(verdict: dict) -> str:
    """One line for the terminal: ``ok (...)`` or how many problems (the warnings follow on stderr)."""
    tolerances = (f"errors <= {verdict['position_tolerance']:g} m and {verdict['orientation_tolerance']:g} rad")
    if verdict["ok"]:
        return f"ok: inside the joint limits, {tolerances}"
    problems = []
    if not verdict["within_joint_limits"]:
        problems.append("joint limits left")
    if not verdict["within_tolerance"]:
        problems.append(f"task error above the tolerance ({tolerances})")
    if not verdict.get("within_inequalities", True):
        problems.append("inequalities left")
    return "WARNING: " + "; ".join(problems)
